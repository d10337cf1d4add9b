"""Run every bench/bench_*.py module, print one table, and save it with the plots under bench/results."""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")
BENCH_DIR = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH_DIR))  # the device modules share bench/benchlib.py
COLUMNS = ("benchmark", "measure", "value", "unit", "target", "met", "baseline")


def load(path: Path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(module)
    return module


def format_value(value: float) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def table(rows: list[dict]) -> str:
    cells = [
        [
            format_value(row.get(c, ""))
            if c == "value"
            else ("yes" if row.get(c) else "NO")
            if c == "met"
            else str(row.get(c, ""))
            for c in COLUMNS
        ]
        for row in rows
    ]
    widths = [max(len(c), *(len(r[i]) for r in cells)) if cells else len(c) for i, c in enumerate(COLUMNS)]

    def line(values: list[str]) -> str:
        return "| " + " | ".join(v.ljust(w) for v, w in zip(values, widths, strict=True)) + " |"

    return "\n".join([line(COLUMNS), line(["-" * w for w in widths]), *(line(r) for r in cells)])


def main() -> int:
    parser = argparse.ArgumentParser(
        description="Run the benchmarks; medians of repeats, ratios within one run."
    )
    parser.add_argument(
        "--quick", action="store_true", help="fewer repeats and smaller sweeps (about a minute per device)"
    )
    parser.add_argument("--only", nargs="*", default=None, help="device names, e.g. mems throwing assembly")
    parser.add_argument("--out", type=Path, default=BENCH_DIR / "results")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    rows: list[dict] = []
    failures: list[str] = []
    for path in sorted(BENCH_DIR.glob("bench_*.py")):
        device = path.stem.removeprefix("bench_")
        if args.only and device not in args.only:
            continue
        started = time.perf_counter()
        print(f"bench: running {device} ...", file=sys.stderr, flush=True)
        try:
            rows += load(path).run(args.out, args.quick)
        except Exception as exc:  # one broken device bench must not hide the others' numbers
            failures.append(f"{device}: {type(exc).__name__}: {exc}")
        print(f"bench: {device} took {time.perf_counter() - started:.1f} s", file=sys.stderr, flush=True)
    print(table(rows))
    met = sum(bool(r.get("met")) for r in rows)
    print(f"\n{met} of {len(rows)} targets met; plots and results.json in {args.out}")
    (args.out / "results.json").write_text(json.dumps(rows, indent=1, default=float))
    (args.out / "results.md").write_text(table(rows) + "\n")
    for failure in failures:
        print(f"bench FAILED {failure}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
