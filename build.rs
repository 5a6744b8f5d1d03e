//! Build script. With feature `embree`: runs bindgen over `wrapper.h` (Embree 4 if found, else 3) into
//! `$OUT_DIR/embree_bindings.rs`, detects the version from the generated constants (Debian ships no
//! pkg-config file for Embree), and emits `cfg(embree3)` / `cfg(embree4)`, the link line and
//! `CAUSTICA_EMBREE_VERSION`. Without the feature it does nothing.
//!
//! Environment: `EMBREE_INCLUDE_DIR` (added as `-I`), `EMBREE_LIB_DIR` (added to the link search path).

fn main() {
    #[cfg(feature = "embree")]
    if std::env::var_os("CARGO_FEATURE_EMBREE").is_some() {
        embree::generate();
    }
}

#[cfg(feature = "embree")]
mod embree {
    use std::env;
    use std::path::PathBuf;

    /// Flag enums whose values are OR-ed together: bitfield newtypes, so any bit pattern is valid.
    /// Every other enum (notably `RTCError`, which Embree may extend) becomes plain integer constants,
    /// never a Rust `enum` (an unknown value would be undefined behaviour).
    const FLAG_ENUMS: &str = "RTCSceneFlags|RTCIntersectContextFlags|RTCRayQueryFlags|RTCFeatureFlags|RTCBuildFlags|RTCCurveFlags";

    pub fn generate() {
        println!("cargo:rerun-if-changed=wrapper.h");
        println!("cargo:rerun-if-env-changed=EMBREE_INCLUDE_DIR");
        println!("cargo:rerun-if-env-changed=EMBREE_LIB_DIR");
        println!("cargo::rustc-check-cfg=cfg(embree3)");
        println!("cargo::rustc-check-cfg=cfg(embree4)");

        let out_dir = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
        let mut builder = bindgen::Builder::default()
            .header("wrapper.h")
            .allowlist_function("rtc.*")
            .allowlist_type("RTC.*")
            .allowlist_var("RTC_.*")
            .default_enum_style(bindgen::EnumVariation::Consts)
            .prepend_enum_name(false)
            .bitfield_enum(FLAG_ENUMS)
            .derive_default(true)
            // The crate's MSRV (Cargo.toml `rust-version`): plain `extern "C"` blocks, not `unsafe extern`.
            .rust_target(bindgen::RustTarget::stable(80, 0).unwrap_or_else(|e| panic!("{e}")))
            // RTC_INVALID_GEOMETRY_ID is `((unsigned int)-1)`, which bindgen's own macro parser skips.
            .clang_macro_fallback()
            .clang_macro_fallback_build_dir(&out_dir)
            .parse_callbacks(Box::new(bindgen::CargoCallbacks::new()));
        if let Some(dir) = env::var_os("EMBREE_INCLUDE_DIR") {
            builder = builder.clang_arg(format!("-I{}", PathBuf::from(dir).display()));
        }
        let bindings = builder.generate().unwrap_or_else(|e| {
            panic!("bindgen failed on wrapper.h (install libembree-dev and libclang-dev, or set EMBREE_INCLUDE_DIR): {e}")
        });
        let text = bindings.to_string();
        std::fs::write(out_dir.join("embree_bindings.rs"), &text).expect("write embree_bindings.rs");

        let [major, minor, patch] = ["RTC_VERSION_MAJOR", "RTC_VERSION_MINOR", "RTC_VERSION_PATCH"].map(|name| {
            constant(&text, name).unwrap_or_else(|| panic!("generated Embree bindings lack {name}; unsupported Embree headers"))
        });
        let lib = match major {
            3 => "embree3",
            4 => "embree4",
            _ => panic!("Embree {major}.{minor}.{patch} found; caustica supports Embree 3 and 4"),
        };
        println!("cargo:rustc-cfg={lib}");
        println!("cargo:rustc-env=CAUSTICA_EMBREE_VERSION={major}.{minor}.{patch}");
        if let Some(dir) = env::var_os("EMBREE_LIB_DIR") {
            let dir = PathBuf::from(dir);
            println!("cargo:rustc-link-search=native={}", dir.display());
            // libembree's own dependencies (libtbb) usually sit beside it; let the linker find them.
            if env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("linux") {
                println!("cargo:rustc-link-arg=-Wl,-rpath-link,{}", dir.display());
            }
        }
        println!("cargo:rustc-link-lib={lib}");
    }

    /// Value of `pub const NAME: <ty> = <value>;` in the generated bindings.
    fn constant(bindings: &str, name: &str) -> Option<u32> {
        let prefix = format!("pub const {name}:");
        let line = bindings.lines().map(str::trim).find(|l| l.starts_with(&prefix))?;
        let value = line.split('=').nth(1)?.trim().trim_end_matches(';').trim();
        value.parse().ok()
    }
}
