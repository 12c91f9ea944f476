"""`pip install .` (meson-python, non-editable) builds a wheel whose extension imports.

TOOLCHAIN.md: a missing SUNDIALS library links fine and only fails at import, so the
installed wheel is imported and run once from outside the source tree.
"""

import os
import subprocess
import sys

from conftest import INPUTS, ROOT


def test_wheel_builds_installs_and_runs(tmp_path):
    env = dict(os.environ)
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-build-isolation", "--no-deps",
                    "--target", str(tmp_path / "site"), str(ROOT)], check=True, env=env)
    # The development venv has an editable install whose meta-path finder would shadow the
    # wheel; drop it so the import really comes from the freshly installed files.
    code = ("import sys; sys.meta_path = [f for f in sys.meta_path if 'editable' not in type(f).__module__];"
            "sys.path.insert(0, sys.argv[1]); import pydriver, os;"
            "assert os.path.dirname(pydriver.__file__).startswith(sys.argv[1]), pydriver.__file__;"
            "r = pydriver.run_deck(sys.argv[2]); print(r.summary['reactions']['B']['F'][2])")
    env.pop("PYTHONPATH", None)
    out = subprocess.run([sys.executable, "-P", "-c", code, str(tmp_path / "site"),
                          str(INPUTS / "six_link_static.nml")],
                         cwd=tmp_path, check=True, capture_output=True, text=True, env=env)
    assert abs(float(out.stdout.strip()) - 75.131) < 1e-3
