"""Throwing test fixtures: a stopgap for the shared harness while its lifecycle target is lost.

``ros_harness.bring_to`` overwrites its ``target`` argument (the lifecycle state) with the node's fully
qualified name, so every managed node it brings up fails with "no transition path from unconfigured to
/throwing_arm". Until the harness is fixed, the throwing tests use this copy that keeps the target
(reported to the harness owner); with a fixed harness the patch is not applied.
"""

from __future__ import annotations

import inspect
from typing import Any, Iterator

import pytest
import ros_harness

from feeder_cell.lifecycle_client import LifecycleClient, LifecycleError

_BUG = "target = node.spec.fully_qualified_name"


def _bring_to(client: Any, node: ros_harness.NodeProcess, target: str) -> str:
    name = node.spec.fully_qualified_name
    lifecycle = LifecycleClient(client, None, name)
    ros_harness.wait_for_graph(client, node, services=[f"{name}/list_parameters"])
    if not lifecycle.is_managed(timeout=1.0):
        return "unmanaged"
    try:
        return lifecycle.bring_to(target)
    except LifecycleError as error:
        raise AssertionError(f"{error}. Node log:\n{node.output()[-4000:]}") from None


@pytest.fixture(scope="module", autouse=True)
def _harness_keeps_lifecycle_target() -> Iterator[None]:
    if _BUG not in inspect.getsource(ros_harness.bring_to):
        yield
        return
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(ros_harness, "bring_to", _bring_to)
        yield
