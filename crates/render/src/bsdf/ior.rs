//! Named indices of refraction: Mitsuba's dielectric IOR table (`ior.h`, values at 589 nm) and RGB
//! complex IORs of common conductors.

use crate::color::Rgb;

/// Mitsuba's table of dielectric indices of refraction (`lookup_ior`), names in lower case.
const DIELECTRIC_IORS: &[(&str, f32)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

/// The IOR of a named dielectric (case-insensitive), or `None` if the name is unknown.
pub fn dielectric_ior(name: &str) -> Option<f32> {
    let lower = name.trim().to_ascii_lowercase();
    DIELECTRIC_IORS
        .iter()
        .find(|(n, _)| *n == lower)
        .map(|(_, v)| *v)
}

/// The names accepted by [`dielectric_ior`], for error messages.
pub fn dielectric_names() -> impl Iterator<Item = &'static str> {
    DIELECTRIC_IORS.iter().map(|(n, _)| *n)
}

/// RGB complex IORs (η, k) of common conductors, relative to vacuum. Source: the Tungsten renderer's
/// `ComplexIorData.hpp` (B. Bitterli), which integrates the measured spectra shipped with Mitsuba
/// (`data/ior/*.eta.spd`, `*.k.spd`) against the sRGB colour matching functions. Mitsuba 3 in RGB mode
/// does the equivalent conversion, so results agree up to the spectral-to-RGB approximation.
const CONDUCTOR_IORS: &[(&str, [f32; 3], [f32; 3])] = &[
    (
        "Ag",
        [0.155_264_65, 0.116_723_3, 0.138_380_7],
        [4.828_343_3, 3.122_246, 2.146_950_4],
    ),
    (
        "Al",
        [1.657_46, 0.880_368_96, 0.521_228_7],
        [9.223_869, 6.269_523, 4.837_001],
    ),
    (
        "Au",
        [0.143_118_96, 0.374_957_04, 1.442_478_6],
        [3.983_160_4, 2.385_720_7, 1.603_215_3],
    ),
    (
        "Cr",
        [4.369_683, 2.916_702_5, 1.654_700_5],
        [5.206_434, 4.231_364_5, 3.754_946_7],
    ),
    (
        "Cu",
        [0.200_437_7, 0.924_033_4, 1.102_212],
        [3.912_948_6, 2.452_847_7, 2.142_188],
    ),
    (
        "Hg",
        [2.398_931_5, 1.440_025_5, 0.909_551_2],
        [6.327_627, 4.371_941_4, 3.421_79],
    ),
    (
        "Ir",
        [3.086_41, 2.082_193_8, 1.617_886_7],
        [5.592_151, 4.067_176, 3.267_261],
    ),
    (
        "Mo",
        [4.483_701, 3.525_458, 2.776_077],
        [4.111_131, 3.420_871_7, 3.150_603],
    ),
    (
        "Rh",
        [2.585_795_4, 1.860_186_6, 1.554_428],
        [6.782_293, 4.702_950_3, 3.976_089],
    ),
    (
        "W",
        [4.370_703, 3.300_297_3, 2.998_266_6],
        [3.500_678, 2.604_865_3, 2.273_193],
    ),
];

/// The RGB complex IOR (η, k) of a named conductor (case-sensitive chemical symbol as in Mitsuba), or
/// `None` if unknown. `"none"` is the perfect mirror η = 0, k = 1.
pub fn conductor_ior(name: &str) -> Option<(Rgb, Rgb)> {
    if name == "none" {
        return Some((Rgb::ZERO, Rgb::ONE));
    }
    CONDUCTOR_IORS
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|(_, e, k)| (Rgb::from_array(*e), Rgb::from_array(*k)))
}

/// The names accepted by [`conductor_ior`], for error messages.
pub fn conductor_names() -> impl Iterator<Item = &'static str> {
    std::iter::once("none").chain(CONDUCTOR_IORS.iter().map(|(n, _, _)| *n))
}
