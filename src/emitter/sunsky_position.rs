//! The sun's position in the sky seen from a place at a date and time: the PSA algorithm of M. Blanco-Muriel,
//! D. C. Alarcón-Padilla, T. López-Moratalla and M. Lara-Coira, "Computing the Solar Vector", Solar Energy
//! 70(5), 2001, as Mitsuba 3.9.1's `sunsky` uses it (`BaseSunskyEmitter::sun_coordinates` in
//! `include/mitsuba/render/sunsky.h`): the Julian day, the ecliptic then celestial coordinates of the sun,
//! the local hour angle, the zenith angle with the parallax correction, and the azimuth turned by π (the
//! emitter's frame is z up, x toward the north).
//!
//! Computed in f32 as Mitsuba computes it: the Julian date (about 2.45 million) is rounded to f32, which
//! moves the time used for the sun's ecliptic position by up to 3 hours (its spacing there is a quarter
//! of a day) while the sidereal time keeps the exact hour; Mitsuba's sun direction is that rounded one.

/// A date and time at a place, as Mitsuba's `DateTimeRecord` and `LocationRecord` hold them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct DateTimePlace {
    pub year: i32,
    pub month: i32,
    pub day: i32,
    pub hour: f32,
    pub minute: f32,
    pub second: f32,
    /// Degrees north.
    pub latitude: f32,
    /// Degrees east.
    pub longitude: f32,
    /// Hours ahead of UTC.
    pub timezone: f32,
}

/// Mean radius of the Earth and the astronomical unit, in km (the parallax correction).
const EARTH_MEAN_RADIUS: f64 = 6371.01;
const ASTRONOMICAL_UNIT: f64 = 149_597_890.0;

/// The sun's zenith angle θ and azimuth φ (radians) in the emitter's local frame: its direction is
/// `(sin θ cos φ, sin θ sin φ, cos θ)`.
pub(super) fn sun_angles(t: &DateTimePlace) -> (f32, f32) {
    use std::f32::consts::{PI, TAU};
    // Universal time in decimal hours, and the Julian day number (integer arithmetic, truncating division).
    let dec_hours = t.hour - t.timezone + (t.minute + t.second / 60.0) / 60.0;
    let aux1 = (t.month - 14) / 12;
    let aux2 = (1461 * (t.year + 4800 + aux1)) / 4 + (367 * (t.month - 2 - 12 * aux1)) / 12
        - (3 * ((t.year + 4900 + aux1) / 100)) / 4
        + t.day
        - 32075;
    let julian_date = aux2 as f32 - 0.5 + dec_hours / 24.0;
    // Days since noon UT of 1 January 2000 (JD 2451545).
    let n = julian_date - 2_451_545.0;

    // Ecliptic longitude and obliquity.
    let omega = 2.1429 - 0.001_039_459_4 * n;
    let mean_longitude = 4.895_063 + 0.017_202_791_698 * n;
    let anomaly = 6.240_06 + 0.017_201_969_9 * n;
    let ecliptic_longitude = mean_longitude + 0.033_416_07 * anomaly.sin() + 0.000_348_94 * (2.0 * anomaly).sin()
        - 0.000_113_4
        - 0.000_020_3 * omega.sin();
    let obliquity = 0.409_092_8 - 6.2140e-9 * n + 0.000_039_6 * omega.cos();

    // Right ascension and declination.
    let sin_lambda = ecliptic_longitude.sin();
    let mut right_ascension = (obliquity.cos() * sin_lambda).atan2(ecliptic_longitude.cos());
    if right_ascension < 0.0 {
        right_ascension += TAU;
    }
    let declination = (obliquity.sin() * sin_lambda).asin();

    // Local coordinates: hour angle, zenith angle, azimuth.
    let gmst = 6.697_424_324_2 + 0.065_709_828_3 * n + dec_hours;
    let lmst = (gmst * 15.0 + t.longitude).to_radians();
    let latitude = t.latitude.to_radians();
    let (sin_lat, cos_lat) = latitude.sin_cos();
    let hour_angle = lmst - right_ascension;
    let cos_hour_angle = hour_angle.cos();
    let mut zenith = (cos_lat * cos_hour_angle * declination.cos() + declination.sin() * sin_lat).acos();
    let mut azimuth = (-hour_angle.sin()).atan2(declination.tan() * cos_lat - sin_lat * cos_hour_angle);
    if azimuth < 0.0 {
        azimuth += TAU;
    }
    zenith += (EARTH_MEAN_RADIUS / ASTRONOMICAL_UNIT) as f32 * zenith.sin();
    (zenith, azimuth - PI)
}
