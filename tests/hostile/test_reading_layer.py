"""The one reading layer (feeder_planner.reading) and the readers' field checks (issue 16 items 1 and 3)."""

from __future__ import annotations

import json
import os
import re
import resource
import time
from pathlib import Path

import pytest

from feeder_planner.assembly import load_assembly
from feeder_planner.assembly.model import assembly_from_text
from feeder_planner.errors import InputError
from feeder_planner.fields_io import finite_number, load_yaml_mapping
from feeder_planner.limits import MAX_FILE_BYTES, MAX_YAML_DEPTH, MAX_YAML_NODES, QUOTE_CHARS, quote
from feeder_planner.parts import load_part
from feeder_planner.reading import check_input_file, parse_yaml, read_text


def yaml_json(document: object) -> str:
    """JSON text that YAML 1.1 reads with the same numbers: a float exponent needs a dot (1.0e+308)."""
    return re.sub(r"(?<![\w.])(-?\d+)(e[+-]\d+)", r"\1.0\2", json.dumps(document))


TRIANGLE = "vertices: [[0, 0], [6, 0], [1.5, 5]]\nlength_unit: cm\n"


def refusal(call, *args) -> InputError:
    """Return the InputError ``call(*args)`` raises (failing the test if it returns)."""
    with pytest.raises(InputError) as caught:
        call(*args)
    assert "\n" not in str(caught.value), "an error is one line"
    return caught.value


def bomb(levels: int = 9, target: str = "vertices") -> str:
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"a{k}: &a{k} [" + ", ".join([f"*a{k - 1}"] * 9) + "]" for k in range(1, levels + 1)]
    return "\n".join(lines) + f"\n{target}: *a{levels}\n"


def test_files_that_are_not_regular_are_refused_by_kind_before_any_open(tmp_path: Path) -> None:
    fifo = tmp_path / "part.yaml"
    os.mkfifo(fifo)  # an open for reading would block until a writer came: the check must not open it
    assert "FIFO" in refusal(load_part, fifo).problem
    assert "character device" in refusal(load_part, "/dev/zero").problem
    assert "directory" in refusal(load_assembly, tmp_path).problem
    missing = refusal(load_part, tmp_path / "nothing.yaml")
    assert missing.field == "<file>" and "cannot read" in missing.problem


def test_a_file_past_the_size_limit_is_refused_from_its_size_without_reading_it(tmp_path: Path) -> None:
    path = tmp_path / "big.yaml"
    with open(path, "wb") as handle:
        handle.truncate(MAX_FILE_BYTES + 1)  # sparse: no disk, and reading it would take 16 MiB
    error = refusal(load_yaml_mapping, path)
    assert f"limit of {MAX_FILE_BYTES} bytes" in error.problem and error.source == str(path)
    at_limit = tmp_path / "ok.yaml"
    at_limit.write_text(TRIANGLE)
    assert check_input_file(at_limit) == len(TRIANGLE)


@pytest.mark.parametrize(
    ("data", "offset"),
    [
        (b"name: caf\xe9\n", 9),  # Latin-1
        ("name: x\n".encode("utf-16"), 0),  # a UTF-16 byte-order mark
        (b"vertices: [[0, 0]]\n\xff\xfe\x00", 19),  # binary garbage after text
    ],
)
def test_text_that_is_not_utf8_names_the_byte_offset(tmp_path: Path, data: bytes, offset: int) -> None:
    path = tmp_path / "part.yaml"
    path.write_bytes(data)
    error = refusal(load_part, path)
    assert f"at offset {offset}" in error.problem and "not UTF-8" in error.problem


def test_a_utf8_byte_order_mark_is_read_as_text(tmp_path: Path) -> None:
    path = tmp_path / "part.yaml"
    path.write_bytes(b"\xef\xbb\xbf" + TRIANGLE.encode())
    assert load_part(path).area == pytest.approx(15e-4)


@pytest.mark.parametrize("target", ["vertices", "name", "length_unit", "density"])
def test_alias_bombs_are_refused_before_construction_in_bounded_time_and_memory(
    tmp_path: Path, target: str
) -> None:
    path = tmp_path / "bomb.yaml"
    path.write_text(bomb(target=target))
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    started = time.process_time()
    error = refusal(load_part, path)
    assert f"more than {MAX_YAML_NODES} YAML nodes" in error.problem
    assert time.process_time() - started < 10.0  # a hang guard: the walk stops at the limit
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 100 * 1024  # KiB


def test_aliases_within_the_limit_are_read_as_yaml_means_them() -> None:
    text = "p: &p [0, 0]\nvertices: [*p, [6, 0], [1.5, 5]]\nlength_unit: cm\n"
    document = parse_yaml(text, "inline")
    assert document["vertices"][0] == [0, 0]


def test_deep_nesting_is_refused_with_the_limit_not_a_recursion_error() -> None:
    for depth in (MAX_YAML_DEPTH + 1, 100_000):
        error = refusal(parse_yaml, "v: " + "[" * depth + "]" * depth, "deep.yaml")
        assert f"nested deeper than the limit of {MAX_YAML_DEPTH}" in error.problem
    assert parse_yaml("v: " + "[" * (MAX_YAML_DEPTH - 1) + "]" * (MAX_YAML_DEPTH - 1), "ok") is not None


def test_service_text_goes_through_the_same_bounds() -> None:
    error = refusal(assembly_from_text, bomb(target="bodies"), "assembly_yaml")
    assert error.source == "assembly_yaml" and "YAML nodes" in error.problem


def test_unsafe_tags_and_broken_yaml_are_input_errors(tmp_path: Path) -> None:
    path = tmp_path / "x.yaml"
    for text in ("v: !!python/object/apply:os.system [ls]\n", "v: [1, 2\n", "a: 1\n---\nb: 2\n", "- 1\n"):
        path.write_text(text)
        error = refusal(load_yaml_mapping, path)
        assert error.field in ("<file>", "<top level>")


def test_huge_integers_are_refused_by_name_not_overflow() -> None:
    error = refusal(finite_number, 10**400, "vertices[1]")
    assert error.field == "vertices[1]" and "too large for a double" in error.problem
    assert "401 digits" in error.problem  # quoted by size, never printed in full


def test_messages_quote_only_a_short_prefix_of_a_value(tmp_path: Path) -> None:
    long_name = "x" * 100_000
    path = tmp_path / "part.yaml"
    path.write_text(json.dumps({"name": long_name, "vertices": [[0, 0], [1, 0], [0, 1]]}))
    error = refusal(load_part, path)
    assert error.field == "name" and len(str(error)) < 300
    assert len(quote(long_name)) < QUOTE_CHARS + 40
    nested = [[list(range(1000))] * 1000]
    assert quote(nested) == "a list of 1 item(s)"


@pytest.mark.parametrize(
    ("document", "field", "words"),
    [
        ({"vertices": [[0, 0], [1e-160, 0], [0, 1e-160]]}, "vertices", "length range"),
        ({"vertices": [[0, 0], [1e150, 0], [0, 1e150]]}, "vertices", "length range"),
        ({"vertices": [[1e5, 0], [1e5 + 1, 0], [1e5, 1]]}, "vertices", "length range"),
        ({"vertices": [[0, 0], [1, 0], [0, 1]], "name": [[1, 2], [3]]}, "name", "a string"),
        ({"vertices": [[0, 0], [1, 0], [0, 1]], "name": "two\nlines"}, "name", "one line"),
        ({"vertices": [[0, 0], [1, 0], [0, 1]], "density": 1e300}, "density", "limit"),
        ({"vertices": [[0, 0], [1, 0], [0, 1]], "length_unit": ["m"]}, "length_unit", "unknown"),
    ],
)
def test_part_fields_out_of_the_models_range_are_refused_by_name(
    tmp_path: Path, document: dict, field: str, words: str
) -> None:
    path = tmp_path / "part.yaml"
    path.write_text(yaml_json(document))
    error = refusal(load_part, path)
    assert error.field == field and words in error.problem, str(error)


def test_the_length_range_allows_a_micrometre_part_and_a_metre_part(tmp_path: Path) -> None:
    path = tmp_path / "part.yaml"
    for unit, size in (("um", 3), ("m", 2.0)):
        path.write_text(json.dumps({"length_unit": unit, "vertices": [[0, 0], [size, 0], [0, size]]}))
        assert load_part(path).area > 0


ASSEMBLY = {
    "name": "pin",
    "bodies": [
        {"name": "ground", "grounded": True, "boxes": [{"min": [-1, -1, -1], "max": [1, 1, 0]}]},
        {"name": "cube", "boxes": [{"min": [-0.5, -0.5, 0], "max": [0.5, 0.5, 1]}]},
    ],
}


def contact(**changes) -> dict:
    return {
        **ASSEMBLY,
        "contacts": [{"a": "cube", "b": "ground", "point": [0, 0, 0], "normal": [0, 0, 1], **changes}],
    }


@pytest.mark.parametrize(
    ("document", "field", "words"),
    [
        (contact(point=[10_000, 0, 0]), "contacts[0].point", "surface"),
        (contact(a=["cube"]), "contacts[0].a", "a string"),
        (contact(point=[10**400, 0, 0]), "contacts[0].point[0]", "too large"),
        (
            {
                **ASSEMBLY,
                "bodies": [
                    ASSEMBLY["bodies"][0],
                    {"name": "p", "convex": [[[0, 0, 1], [1, 0, 1], [0, 1, 1], [0, 0, 2], [0.1, 0.1, 1.1]]]},
                ],
            },
            "bodies[1].convex[0][4]",
            "not in convex position",
        ),
        (
            {
                **ASSEMBLY,
                "bodies": [
                    {**ASSEMBLY["bodies"][0], "boxes": [{"min": [0, 0, -1], "max": [1e308, 1, 0]}]},
                    ASSEMBLY["bodies"][1],
                ],
            },
            "bodies[0].boxes[0].max",
            "length range",
        ),
        ({**ASSEMBLY, "name": {"a": 1}}, "name", "a string"),
    ],
)
def test_assembly_silent_accepts_are_now_refused(
    tmp_path: Path, document: dict, field: str, words: str
) -> None:
    path = tmp_path / "assembly.yaml"
    path.write_text(yaml_json(document))
    error = refusal(load_assembly, path)
    assert error.field == field and words in error.problem, str(error)


def test_a_contact_point_on_one_body_surface_is_still_accepted(tmp_path: Path) -> None:
    # The model's own extreme cases put a point on the ground only (the free body hovering above it).
    path = tmp_path / "assembly.yaml"
    path.write_text(json.dumps(contact()))
    assert len(load_assembly(path).explicit_contacts) == 1


def test_read_text_refuses_a_file_grown_past_the_limit(tmp_path: Path) -> None:
    path = tmp_path / "x.yaml"
    path.write_bytes(b"a: 1\n" * 10)
    assert read_text(path, max_bytes=50) == "a: 1\n" * 10
    assert "limit of 49 bytes" in refusal(read_text, path, 49).problem


def test_an_alias_inside_the_collection_it_names_is_refused() -> None:
    # A recursive value: no field can be one, and whatever walks it would recurse forever.
    with pytest.raises(InputError, match="refers to its own ancestor at line 1"):
        parse_yaml("vertices: &x [[0, 0], *x]", "part.yaml")
    assert parse_yaml("a: &x [1, 2]\nb: [*x, *x]", "ok.yaml") == {"a": [1, 2], "b": [[1, 2], [1, 2]]}
