//! Compiles the C++ shim over OpenSubdiv's Far layer and links `osdCPU`.
//!
//! OpenSubdiv comes from the system (Debian's `libosd-dev`). Debian ships no pkg-config file for it,
//! so pkg-config is asked first (other distributions and local builds may have one) and the Debian
//! default paths are the fallback.

use std::path::{Path, PathBuf};
use std::process::Command;

const MISSING: &str = "OpenSubdiv not found: install Debian's libosd-dev (apt-get install libosd-dev)";

/// Include and library directories from `pkg-config opensubdiv`, if it knows the package.
fn from_pkg_config() -> Option<(Vec<PathBuf>, Vec<PathBuf>)> {
    let query = |flag: &str| -> Option<String> {
        let out = Command::new("pkg-config").args([flag, "opensubdiv"]).output().ok()?;
        out.status.success().then(|| String::from_utf8_lossy(&out.stdout).into_owned())
    };
    let cflags = query("--cflags-only-I")?;
    let libs = query("--libs-only-L")?;
    let dirs = |s: &str, prefix: &str| -> Vec<PathBuf> {
        s.split_whitespace().filter_map(|t| t.strip_prefix(prefix)).map(PathBuf::from).collect()
    };
    Some((dirs(&cflags, "-I"), dirs(&libs, "-L")))
}

fn main() {
    println!("cargo:rerun-if-changed=shim/osd_shim.cpp");
    println!("cargo:rerun-if-env-changed=PKG_CONFIG_PATH");

    let (mut includes, mut lib_dirs) = from_pkg_config().unwrap_or_default();
    if includes.is_empty() {
        includes.push(PathBuf::from("/usr/include"));
    }
    if lib_dirs.is_empty() {
        lib_dirs.push(PathBuf::from("/usr/lib/x86_64-linux-gnu"));
        lib_dirs.push(PathBuf::from("/usr/lib"));
    }

    let header = Path::new("opensubdiv/far/topologyRefiner.h");
    if !includes.iter().any(|dir| dir.join(header).is_file()) {
        panic!("{MISSING} (looked for {} under {includes:?})", header.display());
    }

    cc::Build::new()
        .cpp(true)
        .std("c++14")
        .includes(&includes)
        // The Far templates compiled into the shim assert on internal invariants; an assert would
        // abort the host process, so the shim relies on validation and error codes instead.
        .define("NDEBUG", None)
        .warnings(true)
        .file("shim/osd_shim.cpp")
        .compile("osd_shim");

    for dir in &lib_dirs {
        println!("cargo:rustc-link-search=native={}", dir.display());
    }
    println!("cargo:rustc-link-lib=dylib=osdCPU");
}
