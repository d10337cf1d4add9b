"""Shared helpers of the assembly tests: prepared example assemblies and independent cone membership."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import nnls

from feeder_planner.assembly.model import assembly_from_document, load_assembly
from feeder_planner.assembly.planner import prepare

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "assembly"


@pytest.fixture
def example():
    """prepare(examples/assembly/<name>.yaml, mu, K)."""

    def make(name: str, mu: float | None = None, facets: int = 4):
        return prepare(load_assembly(EXAMPLES / f"{name}.yaml"), mu, facets)

    return make


@pytest.fixture
def from_doc():
    def make(document: dict, mu: float | None = None, facets: int = 4):
        return prepare(assembly_from_document(document), mu, facets)

    return make


def in_cone(generators: np.ndarray, target: np.ndarray, tolerance: float = 1e-9) -> bool:
    """Whether target is a non-negative combination of the rows of generators (NNLS, not the LP)."""
    _, residual = nnls(np.asarray(generators, float).T, np.asarray(target, float))
    return residual <= tolerance


def random_directions(count: int, seed: int) -> np.ndarray:
    g = np.random.default_rng(seed).normal(size=(count, 3))
    return g / np.linalg.norm(g, axis=1, keepdims=True)
