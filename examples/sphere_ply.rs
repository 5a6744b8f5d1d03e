//! Writes a sphere from caustica's own generator (`mesh::shapes::sphere`, the tessellation a scene's
//! `type = "sphere"` gets by default) as a binary PLY, so that another renderer can load exactly the
//! triangles caustica renders. Used by `scripts/bench-vs-mitsuba`.
//!
//! ```text
//! cargo run --release --example sphere_ply -- OUT.ply CX CY CZ RADIUS
//! ```

use std::process::ExitCode;

use caustica::math::Vec3;
use caustica::mesh::{ply::write_ply, shapes::sphere};
use caustica::shape::{SPHERE_RINGS, SPHERE_SEGMENTS};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let numbers: Option<Vec<f32>> = args.get(1..).map(|a| a.iter().map(|s| s.parse().ok()).collect::<Option<_>>()).flatten();
    let (Some(out), Some([cx, cy, cz, radius])) = (args.first(), numbers.as_deref().and_then(|n| <[f32; 4]>::try_from(n).ok())) else {
        eprintln!("usage: sphere_ply OUT.ply CX CY CZ RADIUS");
        return ExitCode::from(2);
    };
    let mesh = sphere(Vec3::new(cx, cy, cz), radius, SPHERE_RINGS, SPHERE_SEGMENTS);
    let tmp = format!("{out}.tmp");
    let written = std::fs::File::create(&tmp)
        .and_then(|f| write_ply(&mesh, f))
        .and_then(|()| std::fs::rename(&tmp, out));
    match written {
        Ok(()) => {
            println!("{out}: {} triangles", mesh.triangle_count());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("{out}: {e}");
            let _ = std::fs::remove_file(&tmp);
            ExitCode::FAILURE
        }
    }
}
