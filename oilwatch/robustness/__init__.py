"""The estimator against a plant that differs from its model the way a real machine does."""

from .cases import CASES, Case, case_by_name
from .report_table import format_table
from .runner import POINTS_PCT, run_robustness

__all__ = ["CASES", "POINTS_PCT", "Case", "case_by_name", "format_table", "run_robustness"]
