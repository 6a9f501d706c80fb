//! Writes the deck of a shear preset into a directory (for inspection).
use dem_verify::deck::shear::shear_deck;
use dem_verify::packing::loose_packing;
use dem_verify::spec::{shear::ShearCase, RollingModel};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let preset = args.get(1).map(String::as_str).unwrap_or("ci");
    let out = std::path::PathBuf::from(args.get(2).map(String::as_str).unwrap_or("shear_deck"));
    let preset = dem_verify::spec::shear::Preset::parse(preset).unwrap();
    let c = ShearCase::preset(preset, RollingModel::Epsd, 0.5, 0.5, 1).unwrap();
    c.validate(false).unwrap();
    let d = shear_deck(&c, &loose_packing(&c));
    std::fs::create_dir_all(&out).unwrap();
    for (n, t) in &d.files {
        std::fs::write(out.join(n), t).unwrap();
    }
}
