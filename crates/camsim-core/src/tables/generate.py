# Generates cie.rs and macbeth.rs beside this script from the colour-science Python package
# (development time only; camsim does not run Python). Usage:
#   python3 -m venv /tmp/cvenv && /tmp/cvenv/bin/pip install colour-science
#   /tmp/cvenv/bin/python generate.py && rustfmt --edition 2021 ../tables.rs
import os
HERE = os.path.dirname(os.path.abspath(__file__))
import colour, numpy as np
def fmt(vals, per=8):
    s = [repr(float(v)) for v in vals]
    lines = []
    for i in range(0, len(s), per):
        lines.append("    " + ", ".join(s[i:i+per]) + ",")
    return "\n".join(lines)
out = []
out.append("//! CIE tables, generated at development time from the `colour-science` Python package %s\n//! (values as published by the CIE; see each table). Do not edit by hand.\n" % colour.__version__)
c = colour.MSDS_CMFS['CIE 1931 2 Degree Standard Observer']
w = np.arange(360, 831, 5)
idx = np.searchsorted(c.wavelengths, w); assert np.all(c.wavelengths[idx] == w)
v = c.values[idx]
out.append("/// First wavelength of the CIE 1931 tables, nm.\npub const CMF_START_NM: f64 = 360.0;\n/// Spacing of the CIE 1931 tables, nm.\npub const CMF_STEP_NM: f64 = 5.0;\n")
for i, n in enumerate("XYZ"):
    out.append("/// CIE 1931 2-degree standard observer colour-matching function %s-bar, 360-830 nm every 5 nm.\n/// Source: CIE 015:2018 Colorimetry, 4th ed., and ISO/CIE 11664-1 (via colour-science\n/// `MSDS_CMFS['CIE 1931 2 Degree Standard Observer']`, 5 nm subset of the 1 nm table).\npub const CIE1931_%s_BAR: [f64; %d] = [\n%s\n];\n" % (n.lower(), n, len(w), fmt(v[:, i])))
for key, rname, desc in [("D65", "D65", "CIE standard illuminant D65 relative SPD (100 at 560 nm).\n/// Source: CIE 015:2018 and ISO/CIE 11664-2 (via colour-science `SDS_ILLUMINANTS['D65']`)"),
                        ("A", "A", "CIE standard illuminant A relative SPD (100 at 560 nm).\n/// Source: CIE 015:2018 and ISO/CIE 11664-2 (via colour-science `SDS_ILLUMINANTS['A']`)"),
                        ("C", "C", "CIE illuminant C relative SPD in the published relative units (105.3 at 560 nm).\n/// Source: CIE 015:2018 (via colour-science `SDS_ILLUMINANTS['C']`)"),
                        ("FL2", "F2", "CIE fluorescent illuminant F2 (cool white) relative SPD,\n/// in the published relative units (not normalised at 560 nm).\n/// Source: CIE 015:2018 (fluorescent lamp tables) (via colour-science `SDS_ILLUMINANTS['FL2']`)"),
                        ("FL11", "F11", "CIE fluorescent illuminant F11 (narrow-band tri-phosphor) relative SPD,\n/// in the published relative units (not normalised at 560 nm).\n/// Source: CIE 015:2018 (fluorescent lamp tables) (via colour-science `SDS_ILLUMINANTS['FL11']`)")]:
    s = colour.SDS_ILLUMINANTS[key]
    st, en, step = s.shape.start, s.shape.end, s.shape.interval
    assert step == 5
    out.append("/// First wavelength of [`%s`], nm.\npub const %s_START_NM: f64 = %r;\n/// %s, %g-%g nm every 5 nm.\npub const %s: [f64; %d] = [\n%s\n];\n" % (rname, rname, float(st), desc, st, en, rname, len(s.values), fmt(s.values)))
open(os.path.join(HERE, "cie.rs"), "w").write("\n".join(out))

out = ["//! Macbeth ColorChecker reflectances, generated at development time from the `colour-science` Python\n//! package %s. Do not edit by hand.\n\n// Measured figures that happen to look like 1/pi are not 1/pi.\n#![allow(clippy::approx_constant)]\n" % colour.__version__]
cc = colour.SDS_COLOURCHECKERS['ColorChecker N Ohta']
names = list(cc.keys())
out.append("/// Patch names in chart order (1 dark skin ... 24 black), as in colour-science / McCamy et al. 1976.\npub const NAMES: [&str; 24] = [\n%s\n];\n" % "\n".join("    %r," % n for n in names).replace("'", '"'))
out.append("/// First wavelength of [`REFLECTANCE`], nm.\npub const START_NM: f64 = 380.0;\n/// Spacing of [`REFLECTANCE`], nm.\npub const STEP_NM: f64 = 5.0;\n")
rows = []
for n in names:
    sd = cc[n]
    assert sd.shape.start == 380 and sd.shape.end == 780 and sd.shape.interval == 5
    rows.append("    // %s\n    [\n%s\n    ]," % (n, "\n".join("    " + l for l in fmt(sd.values).split("\n"))))
out.append("/// Spectral reflectance (fraction) of the 24 ColorChecker patches, 380-780 nm every 5 nm.\n/// Source: N. Ohta, \"The basis of color reproduction engineering\" (Corona-sha, 1997), the measured\n/// Macbeth ColorChecker data (via colour-science `SDS_COLOURCHECKERS['ColorChecker N Ohta']`).\npub const REFLECTANCE: [[f64; 81]; 24] = [\n%s\n];\n" % "\n".join(rows))
open(os.path.join(HERE, "macbeth.rs"), "w").write("\n".join(out))

# lamps.rs: CIE 015:2018 Table 10 (high-pressure discharge lamps, typical LEDs), 380-780 nm every 5 nm.
lamps = [("HP1", "standard high-pressure sodium lamp"), ("HP2", "colour-enhanced high-pressure sodium lamp"),
         ("HP3", "high-pressure metal halide lamp, 3000 K class"), ("HP4", "high-pressure metal halide lamp, 4200 K class"),
         ("HP5", "high-pressure metal halide lamp, 5600 K class"), ("LED-B1", "phosphor-converted blue LED, 2733 K"),
         ("LED-B2", "phosphor-converted blue LED, 2998 K"), ("LED-B3", "phosphor-converted blue LED, 4103 K"),
         ("LED-B4", "phosphor-converted blue LED, 5109 K"), ("LED-B5", "phosphor-converted blue LED, 6598 K"),
         ("LED-BH1", "hybrid: phosphor-converted blue LED and red LED, 2851 K"),
         ("LED-RGB1", "red, green and blue LED mix, 2840 K"), ("LED-V1", "phosphor-converted violet LED, 2724 K"),
         ("LED-V2", "phosphor-converted violet LED, 4070 K")]
out = ["//! CIE 015:2018 *Colorimetry*, 4th ed., Table 10 (see lamps.rs's header). Generated, do not edit by hand.\n\n#![allow(clippy::approx_constant)]\n",
       "/// First wavelength of every table, nm.\npub const START_NM: f64 = 380.0;\n/// Spacing, nm.\npub const STEP_NM: f64 = 5.0;\n",
       "/// (CIE name, what it is, relative SPD 380-780 nm every 5 nm).\npub const LAMPS: [(&str, &str, [f64; 81]); %d] = [" % len(lamps)]
for n, about in lamps:
    sd = colour.SDS_ILLUMINANTS[n]
    assert sd.shape.start == 380 and sd.shape.end == 780 and sd.shape.interval == 5
    out.append('    ("%s", "%s", [\n%s\n    ]),' % (n, about, fmt(sd.values)))
out.append("];\n")
open(os.path.join(HERE, "lamps.rs"), "w").write("\n".join(out))
