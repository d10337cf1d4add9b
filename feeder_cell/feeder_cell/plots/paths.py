"""Plot file names: the format from the extension, checked before anything is computed (no matplotlib)."""

from __future__ import annotations

from pathlib import Path

from feeder_planner.errors import InputError

__all__ = ["PLOT_FORMATS", "check_plot_path"]

# Extension -> matplotlib format. PNG for the README and quick looks, SVG for documents.
PLOT_FORMATS = {".png": "png", ".svg": "svg"}


def check_plot_path(path: str | Path, flag: str = "--plot") -> Path:
    """Return ``path`` as a Path if a plot can be written there, else raise InputError naming ``flag``.

    Checked before any computation so that a typo costs nothing: the extension must be .png or .svg
    (case-insensitive), the folder must exist, and the path must not be a folder.
    """
    if str(path) == "":
        raise InputError(flag, "expected a file name ending in .png or .svg, got an empty string")
    target = Path(path)
    if target.is_dir():
        raise InputError(flag, f"{target} is a folder, expected a file name ending in .png or .svg")
    suffix = target.suffix.lower()
    if suffix not in PLOT_FORMATS:
        got = f"'{target.suffix}'" if target.suffix else "no extension"
        raise InputError(flag, f"{target}: the format comes from the extension, .png or .svg, got {got}")
    if not target.parent.is_dir():
        raise InputError(flag, f"{target}: folder {target.parent} does not exist")
    return target
