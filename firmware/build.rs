//! Link script set-up, and a clear refusal to build the firmware for the host.

use std::{env, fs, path::PathBuf};

fn main() {
    let target = env::var("TARGET").unwrap_or_default();
    if !target.starts_with("thumbv7em-") {
        panic!(
            "dima-firmware runs on the STM32F4 only (target thumbv7em-none-eabihf), not on `{target}`.\n\
             Build it from the firmware/ directory, where .cargo/config.toml selects the target:\n\
             \n    cd firmware && cargo build --release\n\
             \nThe host-side unit tests live in the `dima-firmware-logic` crate: `cargo test-logic`."
        );
    }

    // Put memory.x where the linker finds it, and use cortex-m-rt's link.x.
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    fs::write(out.join("memory.x"), include_bytes!("memory.x")).expect("write memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rustc-link-arg=-Tlink.x");
}
