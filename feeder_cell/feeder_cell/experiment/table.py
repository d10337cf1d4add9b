"""The results table of an experiment: one CSV row per replication, appended as each ends.

A row is flushed before the next replication starts, so an interrupted experiment keeps every finished
replication and resumes where it stopped; a table belongs to one experiment (its digest).
"""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any, Iterator

from feeder_cell.experiment.design import Experiment, Scenario
from feeder_planner.errors import InputError

__all__ = ["COLUMNS", "Results", "iterate_rows", "sorted_rows_text"]

COLUMNS = (
    "experiment",
    "scenario",
    "levels",
    "replication",
    "seed",
    "status",
    "reason",
    "end_state",
    "cycles",
    "good",
    "rejected",
    "window_s",
    "down_s",
    "faults_seen",
    "faults_handled",
    "cycle_times",
    "shares",
    "cpu_s",
)


class Results:
    """The CSV table: one row per replication, appended and flushed as each ends; read back to resume."""

    def __init__(self, path: Path, experiment: Experiment) -> None:
        self.path = path
        self.experiment = experiment
        self.rows: dict[tuple[int, int], dict[str, str]] = {}
        if path.exists() and path.stat().st_size > 0:
            with path.open(newline="") as handle:
                reader = csv.DictReader(handle)
                if tuple(reader.fieldnames or ()) != COLUMNS:
                    raise InputError("--results", f"{path} is not a results table of feeder experiment")
                for row in reader:
                    if row["experiment"] != experiment.digest:
                        raise InputError(
                            "--results",
                            f"{path} holds rows of another experiment ({row['experiment']}, this one is "
                            f"{experiment.digest}): remove it or name another file",
                        )
                    self.rows[(int(row["scenario"]), int(row["replication"]))] = row
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            with path.open("w", newline="") as handle:
                csv.DictWriter(handle, COLUMNS).writeheader()

    def done(self, scenario: int, replication: int) -> bool:
        """Whether the table already has this replication (finished or failed)."""
        return (scenario, replication) in self.rows

    def append(self, scenario: Scenario, replication: int, values: dict[str, Any]) -> None:
        """Append one row and flush it to disk before returning."""
        row = {column: "" for column in COLUMNS}
        row.update(
            experiment=self.experiment.digest,
            scenario=str(scenario.index),
            levels=json.dumps(scenario.levels, sort_keys=True),
            replication=str(replication),
            seed=str(self.experiment.document.get("seed", 0)),
        )
        row.update({k: str(v) for k, v in values.items()})
        with self.path.open("a", newline="") as handle:
            csv.DictWriter(handle, COLUMNS).writerow(row)
            handle.flush()
        self.rows[(scenario.index, replication)] = row


def iterate_rows(results: Results) -> Iterator[dict[str, str]]:
    """Yield the table's rows in (scenario, replication) order (the same whatever order they ended in)."""
    for key in sorted(results.rows):
        yield results.rows[key]


def sorted_rows_text(results: Results) -> str:
    """Return the rows' measured values in key order without timings (equal across worker counts)."""
    keep = [c for c in COLUMNS if c != "cpu_s"]
    return "\n".join(",".join(row[c] for c in keep) for row in iterate_rows(results))
