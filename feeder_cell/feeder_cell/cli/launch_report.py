"""What ``feeder launch`` reports when its run has ended: the JSON result, its summary, its exit code."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from feeder_cell.cli.bag import _summary as bag_summary
from feeder_cell.cli.launch_plan import LaunchPlan
from feeder_cell.launcher import NodeProcess


@dataclass(frozen=True)
class RunOutcome:
    """How a run ended, taken as its processes were stopped."""

    states: dict[str, str]  # each node's lifecycle state after the bring-up
    codes: list[tuple[NodeProcess, bool, int | None]]  # each process, alive before the stop, exit code
    cpu: dict[str, float | None]  # CPU seconds by node
    cell_time: Any  # the CellTime on the cell clock, else None
    bag_stats: dict[str, Any] | None  # the recorder's topics, None without a recorder


def launch_result(plan: LaunchPlan, outcome: RunOutcome) -> dict[str, Any]:
    """Return the launch's JSON result; a cell host that died early is said on stderr, one line for it."""
    args = plan.args
    result: dict[str, Any] = {
        "scene": plan.scene.name,
        "log_dir": str(plan.log_dir),
        "real_time_factor": "max" if args.real_time_factor == 0 else args.real_time_factor,
        "nodes": [_node_report(p, alive, code, outcome) for p, alive, code in outcome.codes],
    }
    hosts = host_reports(outcome.codes)
    if hosts:
        result["hosts"] = hosts
        for report in hosts:
            if report["died_early"]:
                # One line for the host, not one death per node: they are one process.
                print(
                    f"feeder launch: cell host {report['name']} (pid {report['pid']}) ended with exit "
                    f"code {report['exit_code']}, and with it its nodes {', '.join(report['nodes'])}",
                    file=sys.stderr,
                )
    if outcome.cell_time is not None:
        result["cell_time"] = outcome.cell_time.summary()
    stats = outcome.bag_stats
    if stats is not None:
        result["bag"] = {
            "path": str(Path(args.record).resolve()),
            "topics": {n: {"type": s.type_name, "count": s.count} for n, s in sorted(stats.items())},
        }
    return result


def _node_report(p: NodeProcess, alive: bool, code: int | None, outcome: RunOutcome) -> dict[str, Any]:
    return {
        "package": p.package,
        "executable": p.executable,
        "name": p.spec.fully_qualified_name,
        "pid": p.pid,
        "host": p.host,
        "lifecycle": outcome.states.get(p.spec.fully_qualified_name, "unmanaged"),
        "on_exit": p.spec.on_exit,
        "ended_scene": not alive and p.spec.on_exit == "shutdown",
        "died_early": not alive and p.spec.on_exit != "shutdown",
        "exit_code": code,
        "cpu_s": outcome.cpu.get(p.spec.fully_qualified_name),
    }


def host_reports(codes: list[tuple[NodeProcess, bool, int | None]]) -> list[dict[str, Any]]:
    """Return one report per cell host: its pid, nodes, exit code, and whether it died before the end."""
    hosts: dict[str, dict[str, Any]] = {}
    for process, alive, code in codes:
        if not process.host:
            continue
        host = hosts.setdefault(
            process.host,
            {"name": process.host, "pid": process.pid, "nodes": [], "exit_code": code, "died_early": False},
        )
        host["nodes"].append(process.spec.fully_qualified_name)
        host["died_early"] = host["died_early"] or (not alive and process.spec.on_exit != "shutdown")
    return list(hosts.values())


def exit_code(nodes: list[dict[str, Any]]) -> int:
    """Return the launch's exit code: the code of an on_exit node that ended the scene, else 1 if any died.

    A node ended by a signal (negative code) gives 1; a node that died early makes a 0 a 1.
    """
    failed = 1 if any(n["died_early"] for n in nodes) else 0
    for node in nodes:
        if node["ended_scene"]:
            code = node["exit_code"]
            return (code if isinstance(code, int) and code >= 0 else 1) or failed
    return failed


def summary(result: dict[str, Any]) -> str:
    """Return the launch's result as text, one line per node (what ``emit`` prints without --json)."""
    lines = [f"scene {result['scene']}: logs in {result['log_dir']}"]
    if "cell_time" in result:
        t = result["cell_time"]
        lines.append(
            f"  cell clock: {t['cell_s']:.3f} s of cell time in {t['wall_s']:.3f} s of wall time after the "
            f"first quantum: real-time factor {t['achieved_real_time_factor']:.3g} "
            f"(asked {result['real_time_factor']})"
        )
    for n in result["nodes"]:
        state = "DIED EARLY" if n["died_early"] else "ended the scene" if n["ended_scene"] else "stopped"
        lines.append(
            f"  {n['name']} ({n['package']}/{n['executable']}) pid {n['pid']}: {n['lifecycle']}, "
            f"then {state}, exit code {n['exit_code']}"
            + (f", {n['cpu_s']:.1f} s of CPU" if n.get("cpu_s") is not None else "")
        )
    if "bag" in result:
        lines.append(bag_summary(result["bag"]))
    return "\n".join(lines)
