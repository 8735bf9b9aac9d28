"""Layer 6, report: figures, tables and the self-contained HTML pages."""

from boundid.report.figures import (
    PALETTE,
    color_for,
    log_volume_bars,
    method_styles,
    parameter_convergence,
    projection_2d,
    style_for,
    torque_bounds,
    trajectory_comparison,
    volume_history,
    width_ratios,
)
from boundid.report.html import Page, write_index
from boundid.report.output import check_out_dir, recover_folder, replace_folder, write_file_atomically
from boundid.report.tables import (
    deviation_percent,
    estimate_summary,
    format_frame,
    latex_table,
    markdown_table,
    parameter_table,
    widths,
)

__all__ = [
    "PALETTE",
    "Page",
    "check_out_dir",
    "color_for",
    "deviation_percent",
    "estimate_summary",
    "format_frame",
    "latex_table",
    "log_volume_bars",
    "markdown_table",
    "method_styles",
    "parameter_convergence",
    "parameter_table",
    "projection_2d",
    "recover_folder",
    "replace_folder",
    "style_for",
    "torque_bounds",
    "trajectory_comparison",
    "volume_history",
    "width_ratios",
    "widths",
    "write_file_atomically",
    "write_index",
]
