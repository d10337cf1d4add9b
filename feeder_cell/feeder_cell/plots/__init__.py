"""Pictures of the planners' results and of recorded runs (matplotlib, headless).

One module per kind of plot; each has a ``*_figure`` function that draws a result object of the
planners (frozen dataclasses of feeder_planner) into a new ``Figure`` and returns it, and
``common.write_figure`` saves it as PNG or SVG chosen by the file's extension. Plots only draw: the
only mechanics they call are the planners' public model functions (the equilibrium curve x*(theta)).
"""

from feeder_cell.plots.paths import PLOT_FORMATS, check_plot_path

__all__ = ["PLOT_FORMATS", "check_plot_path"]
