//! The stored photon: a compact 32-byte record (method.md §2: "keep the record compact ... ≤ 32 bytes").
//!
//! Layout (`repr(C)`, 32-byte aligned so that two photons share one 64-byte cache line and none straddles
//! two):
//!
//! | bytes | field | encoding |
//! |---|---|---|
//! | 0..12  | position | 3 × f32 |
//! | 12..16 | incident direction ωₚ (unit, pointing back toward the light) | octahedral map, 2 × u16 |
//! | 16..28 | RGB power Φₚ | 3 × f32 (exact; the 32-byte budget allows it, so no shared-exponent loss) |
//! | 28..32 | p_emit | f32: density of the photon's light sample per unit area and projected solid angle (the paper's extra float, `Le/Φ` for emission ∝ power; `photon::emission`); ∞ for a delta light (method.md §4.1) |
//!
//! Direction precision: the octahedral map (Meyer et al. 2010; Cigolle et al. 2014, "A Survey of
//! Efficient Representations for Independent Unit Vectors", JCGT 3(2)) with 16 bits per coordinate
//! (grid step 1/32767, the axes exact), choosing the best of the four surrounding grid points at encode time.
//! Measured worst-case angular error over 10⁶ random directions: 4.3·10⁻⁵ rad (0.0025°); the test asserts
//! < 5·10⁻⁵ rad. (Plain round-to-nearest gives 6.5·10⁻⁵ rad.)
//!
//! **The delta chain** `m` (1 ..= `MAX_DELTA_CHAIN`, the photon's delta bounces; method.md §2.1: T1 may use
//! the photon at an eye vertex of depth d only if `d + m + 1 ≤ max_depth`) is not in the record: every one of
//! its 256 bits is a value bit the estimate reads (the octahedral code uses 65,535 of each u16's 65,536
//! values), so any byte taken for the chain would change every image, also of scenes without a depth limit:
//! 2 × 12-bit directions instead of 16 make the grid step, hence the worst angular error, 16× larger
//! (≈ 7·10⁻⁴ rad), and 4 bits of p_emit's mantissa move q₁ (and ∞, a delta light's p_emit, cannot carry
//! them: it would read as NaN). The chain
//! rides beside the records instead ([`PhotonList`], one byte per photon while the photon pass runs), the
//! kd-tree's build moves it with its photon, and it lands in [`DecodedPhoton`]'s four bytes of padding
//! (`chain`): the gather reads it from the 32-byte line its acceptance test has already loaded, so the
//! filter costs no memory and no extra cache line, and the record and the images of scenes with
//! `max_depth = -1` stay bit for bit what they were.

use crate::math::{Vec2, Vec3};

/// One caustic photon (method.md §2). Construct with [`Photon::new`]; read through the accessors.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Photon {
    position: [f32; 3],
    wi_oct: [u16; 2],
    power: [f32; 3],
    pdf_emit: f32,
}

const _: () = assert!(std::mem::size_of::<Photon>() <= 32);

/// What the density estimate reads of a photon (method.md §3, §4), decoded once when the kd-tree is built
/// and stored beside the records in tree order ([`crate::photon::KdTree::decoded`]): the acceptance test
/// inside the search reads `wi`, and the estimate's sum then finds `pdf_emit` and `power` in the same
/// cache line (one 32-byte line half per photon), instead of a second, random read of the record.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct DecodedPhoton {
    /// [`Photon::wi_world`].
    pub wi: Vec3,
    /// [`Photon::pdf_emit`].
    pub pdf_emit: f32,
    /// [`Photon::power`].
    pub power: Vec3,
    /// The photon's delta bounces, 1 ..= `MAX_DELTA_CHAIN` ([`PhotonList::push`]), in the padding the
    /// alignment leaves (the size assertion below holds with it).
    pub chain: u8,
}

const _: () = assert!(std::mem::size_of::<DecodedPhoton>() == 32);

/// Photons in the photon pass's order with their delta chains, one byte each beside the 32-byte records
/// (the module's docs say why not inside them): what the kd-tree is built over
/// ([`crate::photon::KdTree::build`]). A photon list made from bare records (`From<Vec<Photon>>`, for
/// tests and benchmarks) gives every photon the shortest chain, 1.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PhotonList {
    photons: Vec<Photon>,
    chains: Vec<u8>,
}

impl PhotonList {
    /// Adds `photon`, stored after `chain` delta bounces (1 ..= `MAX_DELTA_CHAIN`).
    pub fn push(&mut self, photon: Photon, chain: u32) {
        debug_assert!((1..=crate::photon::MAX_DELTA_CHAIN).contains(&chain), "delta chain {chain}");
        self.photons.push(photon);
        self.chains.push(chain.min(u32::from(u8::MAX)) as u8);
    }

    /// Appends `other`'s photons.
    pub fn extend(&mut self, other: &PhotonList) {
        self.photons.extend_from_slice(&other.photons);
        self.chains.extend_from_slice(&other.chains);
    }

    #[must_use]
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }

    /// The records, in order.
    #[must_use]
    pub fn photons(&self) -> &[Photon] {
        &self.photons
    }

    /// The delta chains, in the records' order.
    #[must_use]
    pub fn chains(&self) -> &[u8] {
        &self.chains
    }

    /// Multiplies every photon's power by `scale` (the photon pass's 1/N).
    pub fn scale_power(&mut self, scale: f32) {
        for p in &mut self.photons {
            *p = p.with_power(p.power() * scale);
        }
    }

    /// The records and their chains, of one length.
    #[must_use]
    pub fn into_parts(self) -> (Vec<Photon>, Vec<u8>) {
        (self.photons, self.chains)
    }
}

impl From<Vec<Photon>> for PhotonList {
    fn from(photons: Vec<Photon>) -> Self {
        let chains = vec![1; photons.len()];
        PhotonList { photons, chains }
    }
}

/// `±1` with the sign of `v`, and `+1` for ±0 (so the octahedral fold never produces a zero factor).
#[inline]
fn sign_not_zero(v: f32) -> f32 {
    if v >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// Octahedral map of a unit vector to `[-1, 1]²` (Cigolle et al. 2014, listing 1, `float32x3_to_oct`).
#[must_use]
pub fn oct_encode(v: Vec3) -> Vec2 {
    let l1 = v.x.abs() + v.y.abs() + v.z.abs();
    if l1.is_nan() || l1 <= 0.0 || l1.is_infinite() {
        // Zero, NaN or infinite input: a bug upstream; encode +z so the record stays decodable.
        debug_assert!(false, "oct_encode of a non-finite or zero vector {v:?}");
        return Vec2::ZERO;
    }
    let p = Vec2::new(v.x, v.y) / l1;
    if v.z < 0.0 {
        Vec2::new((1.0 - p.y.abs()) * sign_not_zero(p.x), (1.0 - p.x.abs()) * sign_not_zero(p.y))
    } else {
        p
    }
}

/// Inverse of [`oct_encode`]: a unit vector from a point of `[-1, 1]²` (Cigolle et al. 2014, `oct_to_float32x3`).
#[must_use]
pub fn oct_decode(e: Vec2) -> Vec3 {
    let z = 1.0 - e.x.abs() - e.y.abs();
    let (x, y) = if z < 0.0 {
        ((1.0 - e.y.abs()) * sign_not_zero(e.x), (1.0 - e.x.abs()) * sign_not_zero(e.y))
    } else {
        (e.x, e.y)
    };
    Vec3::new(x, y, z).normalize()
}

/// Quantisation levels per side of 0: a coordinate `x ∈ [-1, 1]` is stored as `round(x·S) + S`, so 0 and
/// ±1 (the axes and the octahedron's vertices) are exact.
const OCT_SCALE: f32 = 32767.0;

#[inline]
fn dequantise(q: u16) -> f32 {
    (f32::from(q) - OCT_SCALE) * (1.0 / OCT_SCALE)
}

/// Quantised octahedral encoding that minimises the angular error: of the four grid points around the exact
/// encoding, keep the one whose decoded direction is closest to `v` (Cigolle et al. 2014, "oct32P").
fn encode_direction(v: Vec3) -> [u16; 2] {
    let e = oct_encode(v) * OCT_SCALE;
    let (fx, fy) = (e.x.floor(), e.y.floor());
    let mut best = [0u16; 2];
    // Compare squared chord lengths, not dot products: cos θ = 1 − 5·10⁻⁹ at θ = 10⁻⁴ is 1 in f32.
    let mut best_err = f32::INFINITY;
    for (cx, cy) in [(fx, fy), (fx + 1.0, fy), (fx, fy + 1.0), (fx + 1.0, fy + 1.0)] {
        let q = [
            (cx.clamp(-OCT_SCALE, OCT_SCALE) + OCT_SCALE) as u16,
            (cy.clamp(-OCT_SCALE, OCT_SCALE) + OCT_SCALE) as u16,
        ];
        let err = (decode_direction(q) - v).length_squared();
        if err < best_err {
            best_err = err;
            best = q;
        }
    }
    best
}

#[inline]
fn decode_direction(q: [u16; 2]) -> Vec3 {
    oct_decode(Vec2::new(dequantise(q[0]), dequantise(q[1])))
}

impl Photon {
    /// A photon at `position` that arrived from direction `wi_world` (unit, pointing back toward the light),
    /// carrying RGB `power`, emitted from a light sample of density `pdf_emit` (per unit area and projected
    /// solid angle, method.md §4).
    #[must_use]
    pub fn new(position: Vec3, wi_world: Vec3, power: Vec3, pdf_emit: f32) -> Self {
        debug_assert!((wi_world.length_squared() - 1.0).abs() < 1e-3, "wi_world not unit: {wi_world:?}");
        // p_emit = ∞ marks a delta light's photon (method.md §4.1).
        debug_assert!(power.is_finite() && pdf_emit >= 0.0, "non-finite photon power {power:?} or bad p_emit {pdf_emit}");
        Self {
            position: position.to_array(),
            wi_oct: encode_direction(wi_world),
            power: power.to_array(),
            pdf_emit,
        }
    }

    /// The same photon with another power (the photon pass scales by 1/N once N is known).
    #[must_use]
    pub fn with_power(&self, power: Vec3) -> Self {
        debug_assert!(power.is_finite(), "non-finite photon power {power:?}");
        Self { power: power.to_array(), ..*self }
    }

    /// Where the photon was stored.
    #[inline]
    #[must_use]
    pub fn position(&self) -> Vec3 {
        Vec3::from_array(self.position)
    }

    /// Position as an array (the kd-tree reads single coordinates).
    #[inline]
    #[must_use]
    pub(crate) fn position_array(&self) -> &[f32; 3] {
        &self.position
    }

    /// Incident direction ωₚ (unit, pointing back toward where the light came from), decoded from 32 bits.
    #[inline]
    #[must_use]
    pub fn wi_world(&self) -> Vec3 {
        decode_direction(self.wi_oct)
    }

    /// RGB power Φₚ.
    #[inline]
    #[must_use]
    pub fn power(&self) -> Vec3 {
        Vec3::from_array(self.power)
    }

    /// `p_emit`: density of the photon's light sample per unit area and projected solid angle
    /// (method.md §4: enters q₁ = N·p_emit·|cos θ|·ΔA/α); ∞ for a delta light's photon (§4.1).
    #[inline]
    #[must_use]
    pub fn pdf_emit(&self) -> f32 {
        self.pdf_emit
    }

    /// The fields the density estimate reads, decoded, with the photon's delta `chain` (kept beside the
    /// record, [`PhotonList`]).
    #[must_use]
    pub fn decoded(&self, chain: u8) -> DecodedPhoton {
        DecodedPhoton { wi: self.wi_world(), pdf_emit: self.pdf_emit, power: self.power(), chain }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;

    fn uniform_sphere(u: Vec2) -> Vec3 {
        let z = 1.0 - 2.0 * u.x;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * std::f32::consts::PI * u.y;
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    #[test]
    fn size_and_alignment() {
        assert_eq!(std::mem::size_of::<Photon>(), 32);
        assert_eq!(std::mem::align_of::<Photon>(), 32);
    }

    #[test]
    fn direction_round_trip_error_is_bounded() {
        let mut max_err = 0.0f64;
        let mut check = |w: Vec3| {
            let p = Photon::new(Vec3::ZERO, w, Vec3::ONE, 1.0);
            let d = p.wi_world();
            assert!((d.length() - 1.0).abs() < 1e-6, "decoded direction not unit: {d:?}");
            // Angle in f64 from the cross/dot pair (accurate for tiny angles, unlike acos).
            let (a, b) = (w.as_dvec3(), d.as_dvec3());
            let ang = a.cross(b).length().atan2(a.dot(b));
            max_err = max_err.max(ang);
        };
        let mut s = Sampler::for_key(1, 2, 3);
        for _ in 0..1_000_000 {
            check(uniform_sphere(s.next_2d()));
        }
        // The folds and poles: ±axes, the octahedron's edges and the z = 0 seam.
        for w in [
            Vec3::X,
            -Vec3::X,
            Vec3::Y,
            -Vec3::Y,
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, -1e-7),
            Vec3::new(1.0, -1.0, -1.0),
        ] {
            check(w.normalize());
        }
        assert!(max_err < 5e-5, "max angular error {max_err} rad");
        assert!(max_err > 1e-6, "16-bit quantisation cannot be this exact: {max_err}");
    }

    #[test]
    fn power_position_and_pdf_emit_round_trip_exactly() {
        let pos = Vec3::new(1.25e-3, -7.0e4, 3.0);
        let power = Vec3::new(1e-30, 0.5, 6.5e20);
        let p = Photon::new(pos, Vec3::new(0.6, 0.0, -0.8), power, 123.456);
        assert_eq!(p.position(), pos);
        assert_eq!(p.position_array(), &pos.to_array());
        assert_eq!(p.power(), power);
        assert_eq!(p.pdf_emit(), 123.456);
        for w in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z] {
            assert_eq!(Photon::new(pos, w, power, 1.0).wi_world(), w, "axes are exact");
        }
    }

    /// The chain travels beside the record, through the power's scaling, into the decoded photon; the
    /// record itself is what it was.
    #[test]
    fn the_chain_rides_beside_the_record() {
        let mut list = PhotonList::default();
        let record = |i: u32| Photon::new(Vec3::splat(i as f32), Vec3::Z, Vec3::new(1.0, 2.0, 3.0), 0.5);
        for chain in 1..=crate::photon::MAX_DELTA_CHAIN {
            list.push(record(chain), chain);
        }
        let mut more = PhotonList::default();
        more.push(record(0), 3);
        list.extend(&more);
        list.scale_power(0.25);
        assert_eq!(list.len(), 17);
        for (i, (p, &c)) in list.photons().iter().zip(list.chains()).enumerate() {
            let (at, chain) = if i == 16 { (0, 3) } else { (i as u32 + 1, i as u8 + 1) };
            assert_eq!(c, chain);
            assert_eq!(*p, record(at).with_power(Vec3::new(0.25, 0.5, 0.75)));
            assert_eq!(p.decoded(c).chain, chain);
        }
        assert_eq!(PhotonList::from(vec![record(1), record(2)]).chains(), &[1, 1]);
    }
}
