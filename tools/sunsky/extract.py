#!/usr/bin/env python3
"""Extract the RGB tables of Mitsuba 3's `sunsky` emitter into octolux's compact data file.

Reads the datasets that ship with the Mitsuba 3 pip package (`mitsuba/data/sunsky/`:
`sunsky_datasets.bin` and `sampling_data.bin`, Mitsuba's `tensor_file` format) and writes
`crates/octolux/data/sunsky/sunsky_rgb.bin`: little-endian float32 arrays, in this order,
C-ordered, without header:

  sky_params   [10 turbidity][2 albedo][6 elevation control points][3 RGB][9 parameters]
  sky_radiance [10 turbidity][2 albedo][6 elevation control points][3 RGB]
  sun_rgb      [10 turbidity][30 sun elevations 2°, 5°, ..., 89°][3 RGB]

`sky_*` are Mitsuba's `sky_params_rgb` / `sky_rad_rgb` (Hosek & Wilkie 2012) as they are.
`sun_rgb` is Mitsuba's spectral `sun_irradiance` table (11 wavelengths 320..720 nm) turned into
linear sRGB the way Mitsuba 3.9 does in RGB mode: XYZ = mean over the 11 wavelengths of
CIE 1931 xyz(λ) times the value, then Mitsuba's XYZ -> sRGB matrix (Mitsuba multiplies the result
by SPEC_TO_RGB_SUN_CONV · CIE_Y_NORMALIZATION later; octolux does the same at run time).

Usage: python tools/sunsky/extract.py [--mitsuba-data DIR] [--out FILE]
(DIR defaults to the `data/sunsky` folder of the `mitsuba` package importable by this Python;
the CIE curves come from that package too, so run it with Mitsuba 3's environment.)
"""

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import tensor_file  # noqa: E402

WAVELENGTHS = np.arange(320.0, 721.0, 40.0)
# Mitsuba's xyz_to_srgb (Rec. 709 primaries, D65).
XYZ_TO_SRGB = np.array(
    [[3.240479, -1.537150, -0.498535], [-0.969256, 1.875991, 0.041556], [0.055648, -0.204043, 1.057311]]
)


def main():
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mitsuba-data", help="folder holding sunsky_datasets.bin and sampling_data.bin")
    ap.add_argument("--out", default=os.path.join(root, "crates", "octolux", "data", "sunsky", "sunsky_rgb.bin"))
    args = ap.parse_args()

    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    data_dir = args.mitsuba_data or os.path.join(os.path.dirname(mi.__file__), "data", "sunsky")
    ds = tensor_file.read(os.path.join(data_dir, "sunsky_datasets.bin"))
    sp = tensor_file.read(os.path.join(data_dir, "sampling_data.bin"))

    sky_params = ds["sky_params_rgb"]
    sky_rad = ds["sky_rad_rgb"]
    assert sky_params.shape == (10, 2, 6, 3, 9), sky_params.shape
    assert sky_rad.shape == (10, 2, 6, 3), sky_rad.shape

    sun_irr = sp["sun_irradiance"].astype(np.float64)
    assert sun_irr.shape == (10, 30, 11), sun_irr.shape
    xyz = np.array([np.array(mi.cie1931_xyz(float(w)), dtype=np.float64) for w in WAVELENGTHS])  # [11, 3]
    XYZ = np.einsum("tew,wc->tec", sun_irr, xyz) / len(WAVELENGTHS)
    sun_rgb = np.einsum("rc,tec->ter", XYZ_TO_SRGB, XYZ)

    out = np.concatenate([sky_params.ravel(), sky_rad.ravel(), sun_rgb.ravel()]).astype("<f4")
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    out.tofile(args.out)
    print(f"wrote {args.out}: {out.size} floats ({out.nbytes} bytes)")


if __name__ == "__main__":
    main()
