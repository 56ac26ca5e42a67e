"""The long fuzz run of every reader (issue 16): mutated files (bytes, tokens, structure, encodings, sizes;
and mutations that keep the meaning) through each reader, counted by outcome. The contract: a clean one-line
DenavitError or an accepted file (with the same numbers where the meaning is kept); 0 other exceptions, 0 hangs.

Run: ``python benchmarks/fuzz_readers.py --cases 3000 [--seed 0] [--readers "sweep csv,urdf"]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from fuzzing import campaign  # noqa: E402 (the shared generator lives beside the tests)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--cases", type=int, default=3000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--readers", default=None, help="comma-separated subset")
    args = ap.parse_args()
    t0 = time.perf_counter()
    res = campaign(args.cases, seed=args.seed, readers=set(args.readers.split(",")) if args.readers else None)
    print(f"{'reader':<32} {'cases':>7} {'clean errors':>13} {'accepted':>9} {'other exceptions':>17} {'hangs':>6}")
    for name, c in res.items():
        print(
            f"{name:<32} {c['cases']:>7} {c['clean errors']:>13} {c['accepted']:>9} {c['other exceptions']:>17}"
            f" {c['hangs']:>6}"
        )
        for f in sorted(set(c["failures"]))[:5]:
            print(f"    {f[:200]}")
    total = sum(c["cases"] for c in res.values())
    print(f"{total} cases in {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
