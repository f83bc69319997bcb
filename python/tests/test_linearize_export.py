"""`agvsim linearize` prints the poles a user gets from its exported matrices (numpy's
eigenvalues, mapped as MATLAB's d2c maps them: ln(z)/Ts)."""

import json
import re

import numpy as np


def parse_poles(line):
    poles = []
    for item in line.split(None, 2)[2].split(", "):
        m = re.fullmatch(r"(-?[0-9.]+)(?:([+-][0-9.]+)i)?", item.strip())
        assert m, item
        poles.append(complex(float(m.group(1)), float(m.group(2) or 0)))
    return poles


def test_the_printed_poles_are_the_exported_models(cli, root, tmp_path):
    out = cli("linearize", "scenes/lab_offset_120mm.toml", "--export", tmp_path / "agv.json").stdout
    printed = parse_poles(next(l for l in out.splitlines() if l.startswith("poles (1/s)")))
    model = json.loads((tmp_path / "agv.json").read_text())
    z = np.linalg.eigvals(np.array(model["A"]))
    exact = np.log(z.astype(complex)) / model["Ts_s"]
    assert len(printed) == len(exact)
    for p in printed:
        nearest = exact[np.argmin(abs(exact - p))]
        # Printed to 2 or 3 decimals.
        assert abs(nearest - p) < 0.006, (p, nearest)
    # The fast electrical poles are where the zero-order hold puts them, not at (z - 1)/Ts.
    fastest = min(exact.real)
    assert fastest < -370 and min(p.real for p in printed) < -370, printed
