//! Writes the Stribeck effect the stick–slip renderer produces (the transition's duration against
//! the hand's speed, and μ after breakaway, for hand speeds from 1 to 40 mm/s) with the default
//! material:
//!
//! ```sh
//! cargo run --release -p viewer --example stribeck -- docs/figures/stribeck.png
//! ```

use friction::FrictionMaterial;

fn main() -> anyhow::Result<()> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "docs/figures/stribeck.png".into());
    let material = FrictionMaterial::default();
    let speeds = [0.001, 0.002, 0.004, 0.008, 0.012, 0.02, 0.04];
    let slides = viewer::stribeck::sweep(material, &speeds);
    viewer::stribeck::write_png(&out, &material, &slides)?;
    println!("wrote {out}");
    Ok(())
}
