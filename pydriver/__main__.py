"""Command line: ``python -m pydriver run DECK [--out DIR] [--plots]``."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from pydriver.deck import DeckError, RunError, run_deck


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pydriver", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run one or more decks")
    run.add_argument("decks", nargs="+", help="namelist deck(s)")
    run.add_argument("--out", help="output directory (default results/<deck stem>/; one deck only)")
    run.add_argument("--plots", action="store_true", help="also write PNG plots (matplotlib)")
    study = sub.add_parser("study", help="UH-60 studies: figures 5.6/5.12, 5.9 and refinement")
    study.add_argument("name", choices=["shapes", "cy-sweep", "refine"],
                       help="shapes: rest vs hover plots; cy-sweep: frequency against c_y and the "
                            "flap crossing; refine: first frequency for n = 11, 22, 44, 88")
    study.add_argument("--out", default="results/studies", help="output directory")
    args = parser.parse_args(argv)
    if args.command == "study":
        from pydriver.study import run_study
        print(run_study(args.name, Path(args.out)))
        return 0
    if args.out and len(args.decks) > 1:
        parser.error("--out takes one deck")
    status = 0
    for deck in args.decks:
        out = Path(args.out) if args.out else Path("results") / Path(deck).stem
        try:
            res = run_deck(deck, out=out, plots=args.plots)
        except (DeckError, RunError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            status = 1
            continue
        s = res.summary
        print(f"{s['case']} ({s['analysis']}): {s['wall_time_s']:.3f} s, "
              f"max |g| = {s['max_constraint_violation_m']:.2e} m -> {out}")
        print(json.dumps(s["reactions"]))
    return status


if __name__ == "__main__":
    sys.exit(main())
