"""Export the raw channels of the upstream JPK file to raw.csv (needs afmformats; not run by the tests).

    pip install afmformats==0.18.7
    python export_raw.py force-save-example.jpk-force raw.csv

The file is docs/data/force-save-example.jpk-force of https://github.com/AFM-analysis/afmformats
(MIT; see LICENSE and README.md). afmformats converts the instrument's voltages to SI with the
calibration stored in the file (spring constant, sensitivity); this script only writes them out:
time [s], segment (0 approach, 1 retract), the capacitive sensor's height [nm] and the force [nN].
"""
import sys

import afmformats


def main(src: str, dst: str) -> None:
    g = afmformats.load_data(src)[0]
    md = g.metadata
    t, seg = g["time"], g["segment"]
    h_nm, f_nn = g["height (measured)"] * 1e9, g["force"] * 1e9
    with open(dst, "w", encoding="utf-8", newline="\n") as f:
        f.write("t,segment,height_nm,force_nN\n")
        for row in zip(t, seg, h_nm, f_nn):
            f.write(f"{row[0]:.4f},{int(row[1])},{row[2]:.3f},{row[3]:.5f}\n")
    print(f"spring constant {md['spring constant']!r} N/m, sensitivity {md['sensitivity']!r} m/V, "
          f"{len(t)} rows, rate {md['rate approach']} Hz", file=sys.stderr)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
