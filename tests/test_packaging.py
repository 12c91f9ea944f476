"""`pip install .` (meson-python, non-editable) builds a wheel whose extension imports.

A missing SUNDIALS library links fine and only fails at import (undefined symbol), so the
installed wheel is imported and run once from outside the source tree.  The product wheel is
built without the test and benchmark probes (meson option ``probes``, default off; issue 23):
these tests check that its extension has none and that it runs decks without them.
"""

import os
import re
import subprocess
import sys
import textwrap

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
            "import pydriver._rotorcable as ext; assert not hasattr(ext, 'rotorcable_probes');"
            "r = pydriver.run_deck(sys.argv[2]); print(r.summary['reactions']['B']['F'][2])")
    env.pop("PYTHONPATH", None)
    out = subprocess.run([sys.executable, "-P", "-c", code, str(tmp_path / "site"),
                          str(INPUTS / "six_link_static.nml")],
                         cwd=tmp_path, check=True, capture_output=True, text=True, env=env)
    assert abs(float(out.stdout.strip()) - 75.131) < 1e-3


def test_every_example_deck_ships_in_the_wheel():
    """meson.build lists the decks of inputs/ and the tables they read one by one (meson has no glob):
    none forgotten."""
    text = (ROOT / "meson.build").read_text()
    missing = [p.name for pattern in ("*.nml", "*.csv") for p in INPUTS.glob(pattern)
               if f"'inputs/{p.name}'" not in text]
    assert not missing, missing


def test_fresh_venv_gives_the_whole_tool(tmp_path):
    """A user's `pip install` of the wheel into a new venv (issue 22): the dependencies come with
    it (plots, report and progress bar need no extras), the example decks ship as package data,
    --version, the references (keys, outputs, docs; issue 37), examples, init (whose header points
    to commands that work), run --plots --report, a sweep and a study all work outside the source
    tree, and the study's CSV reads back as numbers."""
    env = dict(os.environ)
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    env.pop("PYTHONPATH", None)
    wheels = tmp_path / "wheels"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-build-isolation", "--no-deps", "-w",
                    str(wheels), str(ROOT)], check=True, env=env)
    venv = tmp_path / "v"
    subprocess.run([getattr(sys, "_base_executable", sys.executable), "-m", "venv", str(venv)], check=True)
    wheel = next(wheels.glob("rotorcable-*.whl"))
    subprocess.run([str(venv / "bin" / "pip"), "install", "-q", str(wheel)], check=True, env=env)
    work = tmp_path / "work"
    work.mkdir()
    exe = str(venv / "bin" / "rotorcable")
    user_env = {k: v for k, v in env.items() if k not in ("VIRTUAL_ENV",)}
    user_env["PATH"] = str(venv / "bin") + os.pathsep + "/usr/bin:/bin"

    def run(*args):
        done = subprocess.run([exe, *args], cwd=work, capture_output=True, text=True, env=user_env, timeout=600)
        assert done.returncode == 0, (args, done.stdout, done.stderr)
        assert "Traceback" not in done.stderr
        return done.stdout

    assert run("--version").startswith("rotorcable ")
    # The reference at hand (issue 37), from an empty directory: the installed package carries no
    # docs/, the commands generate the references from its schema and output table.
    from pydriver.schema import GROUPS
    keys = run("keys")
    assert all(f"\n&{g}\n" in keys for g in GROUPS) and "\n  n_bodies\n" in keys
    assert "\n  t_end\n" in run("keys", "solver.t_end")
    assert "\n  damage_per_hour\n" in run("outputs") and "frequency_vs_cy.csv" in run("outputs")
    assert run("docs", "--format", "html").startswith("<!DOCTYPE html>")
    assert run("keys", "--format", "markdown") + "\n" == (ROOT / "docs" / "deck_reference.md").read_text()
    module = subprocess.run([str(venv / "bin" / "python"), "-m", "pydriver.deck_reference"], cwd=work,
                            capture_output=True, text=True, env=user_env, timeout=120)
    assert module.returncode == 0 and module.stdout.startswith("# Deck reference") and not module.stderr
    assert not list(venv.glob("lib/python*/site-packages/docs")) and not list(work.iterdir())
    # every deck of inputs/ ships, and every table a deck reads
    n_files = len(list(INPUTS.glob("*.nml"))) + len(list(INPUTS.glob("*.csv")))
    assert f"copied {n_files} example files" in run("examples", "ex")
    assert f"kept {n_files} already there" in run("examples", "ex")  # never overwrites
    run("init", "mine.nml", "--like", "six_link_static.nml")         # the name as listed, suffix and all
    header = (work / "mine.nml").read_text().split("\n&", 1)[0]
    assert "a new deck" in header
    # Every command init's header names works in the installed tool and explains keys or outputs.
    commands = re.findall(r"`(rotorcable [^`]+)`", header)
    assert len(commands) >= 3 and "docs/" not in header
    for command in commands:
        assert "\n  " in run(*command.split()[1:]), command
    text = run("run", "mine.nml", "--plots", "--report", "--out", "r1")
    assert "F_B [N]" in text and (work / "r1" / "report.html").is_file() and (work / "r1" / "shape.png").is_file()
    run("sweep", "ex/uh60_part2_modal.nml", "--set", "springs.c_beta=20,35", "--out", "sw", "--jobs", "1")
    assert (work / "sw" / "sweep.csv").is_file()
    run("study", "cy-sweep", "--out", "st")
    rows = (work / "st" / "frequency_vs_cy.csv").read_text().splitlines()
    assert [float(x) for x in rows[1].split(",")][0] == 1.0          # numbers, not "np.float64(1.0)"
    # The product carries no probes: no rotorcable_probes module, no probe symbol in the extension,
    # and a probe called anyway (pydriver.core_probes ships for a build with them) says which build
    # option adds them.
    check = textwrap.dedent("""\
        import pydriver, pydriver._rotorcable as ext, pydriver.core_probes as probes
        from pydriver.analyses.dynamics import start_state
        assert not hasattr(ext, "rotorcable_probes") and not probes.HAS_PROBES
        m = pydriver.Model.from_deck("ex/six_link_static.nml")
        start = m.core.consistent_start(*start_state(m))      # the run API's own routines
        assert abs(m.core.constraint_residual(start["q"])).max() < 1e-8
        try:
            probes.rank_margin(m.core, start["q"])
        except probes.ProbesNotBuilt as e:
            assert "-Dprobes=true" in str(e), e
        else:
            raise AssertionError("a probe ran in the product wheel")
        print(ext.__file__)
        """)
    done = subprocess.run([str(venv / "bin" / "python"), "-c", check], cwd=work, capture_output=True, text=True,
                          env=user_env, timeout=120)
    assert done.returncode == 0, (done.stdout, done.stderr)
    so = done.stdout.strip().splitlines()[-1]
    symbols = subprocess.run(["nm", "-D", "--defined-only", so], capture_output=True, text=True).stdout
    assert symbols and "rc_probe" not in symbols and "rotorcable_probes" not in symbols
    assert "rc_constraint_residual" in symbols
