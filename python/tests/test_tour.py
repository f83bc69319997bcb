"""docs/python_tour.py (the notebook as a script) runs and shows what it says."""

import re
import subprocess
import sys


def test_the_tour_runs_calibrates_and_draws(root, tmp_path):
    p = subprocess.run([sys.executable, "docs/python_tour.py", str(tmp_path)], cwd=root,
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    out = p.stdout
    # The calibration finds the worn machine's friction and clipping ...
    coulomb = float(re.search(r"motor.coulomb_Nm +([0-9.]+) N m", out).group(1))
    limit = float(re.search(r"battery.drive_limit_V +([0-9.]+) V", out).group(1))
    assert abs(coulomb - 0.05) < 0.001 and abs(limit - 11) < 0.05, out
    assert re.search(r"coulomb_friction +motor.coulomb_Nm +accepted", out), out
    before, after = map(float, re.search(r"mean fit ([0-9.]+) % -> ([0-9.]+) %", out).groups())
    assert after > before + 10, out
    # ... and the gear play keeps a limit cycle going at both gains, as the text says.
    assert out.count("limit cycle +/-") == 2, out
    for png in ["run_lateral_error.png", "calibration_fit.png"]:
        data = (tmp_path / png).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000, png
