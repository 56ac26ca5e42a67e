"""Reports: the static figures of an identification or a model, and one self-contained HTML file.

* :func:`write_figures` / :func:`write_model_figures` -- PNG (and/or SVG) files of :mod:`denavit.plotting`
  (matplotlib).
* :func:`write_report` -- an identification: an interactive 3-D view (measured points, fitted circles, centres,
  axes, the bounding box, the frames of the identified convention, of ED-H (or modified DH) and of the nominal
  model, origin paths), residual and parameter-error charts, and the tables (identified values, one-sigma,
  nominal, differences; axes; consecutive-axis relations; bounding box; notes).
* :func:`write_model_report` -- a robot: its frames beside those of another convention or another robot file
  (Guo et al. Figs. 6-7), the path of every frame origin while each joint moves (Guo et al. Fig. 3), and the tables.
* :func:`write_calibration_report` -- a whole-model calibration; :func:`write_compensation_report` -- a
  compensated program.

Every page is read in a minute: a summary first (what was measured, the model, the fit, the accuracy before
and after where known), then the 3-D view (its camera and aspect set from what it draws,
:func:`denavit.plotting.scene_view`), then the tables with a unit in every header.

The HTML file works offline and weighs under 1 MB: plotly.js is inlined once per page, as the gzip'ed partial
bundle :data:`PLOTLY_BUNDLE` (the trace types the reports draw), inflated by the browser's own
``DecompressionStream`` and run by the page's one loader, which then draws every figure from its JSON. There
is no other script, style sheet, font or image to fetch. Legend entries are grouped: a click on a joint
or a convention shows or hides all of its traces (double-click isolates it). Every number in a table is a
``<td>`` with a class naming its column and a ``data-value`` attribute holding the full-precision value in the
table's display unit, so that the report can be read by programs as well as people.

Files are written whole or not at all (:func:`denavit.io.output.write_text`). plotly and matplotlib are the
optional ``plot`` extra; a missing one raises :class:`~denavit.errors.DenavitError` naming
the command for the installation at hand
(:func:`denavit.plotting.install_hint`).

Units: lengths in ``length`` (default mm, as in Hayat et al.), angles in ``angle`` (default deg), SI inside."""

from .calibration import calibration_report_html, write_calibration_report
from .compensation import POSITION_ROWS, compensation_report_html, write_compensation_report
from .html import DECIMALS, FIGURE_FORMATS, PLOTLY_BUNDLE, PLOTLY_JS_VERSION, VIEW_ID, fmt_value

# (the charts drawn alone by tests/test_plotting.py)
from .identification import _parameter_chart, _residual_chart, report_html, write_figures, write_report  # noqa: F401
from .model import model_report_html, write_model_figures, write_model_report
from .validation import validation_report_html, write_validation_figures, write_validation_report

__all__ = [
    "DECIMALS",
    "FIGURE_FORMATS",
    "PLOTLY_BUNDLE",
    "PLOTLY_JS_VERSION",
    "POSITION_ROWS",
    "VIEW_ID",
    "calibration_report_html",
    "compensation_report_html",
    "fmt_value",
    "model_report_html",
    "report_html",
    "validation_report_html",
    "write_calibration_report",
    "write_compensation_report",
    "write_figures",
    "write_model_figures",
    "write_model_report",
    "write_report",
    "write_validation_figures",
    "write_validation_report",
]
