//! Rewrite the crate's `data/cornell.obj`, `data/cornell.mtl` and
//! `data/cornell.view` from the code (`generate::write_cornell_data`),
//! after changing the Cornell data. The unit test
//! `cornell_data_files_match_the_code` fails until they are rewritten.
//!
//! ```text
//! cargo run --example write_cornell_data
//! ```
//!
//! (A generator, not a test: as an ignored test it would run under
//! `cargo test -- --include-ignored`, which runs the scene tests, and
//! rewrite the files while that unit test reads them.)

use std::path::Path;

fn main() -> std::io::Result<()> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
    packtrace::protocol::generate::write_cornell_data(&dir)?;
    println!(
        "wrote cornell.obj, cornell.mtl and cornell.view in {}",
        dir.display()
    );
    Ok(())
}
