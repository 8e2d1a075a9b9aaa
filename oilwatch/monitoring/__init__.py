"""Monitoring a recorded machine: the estimator on a record (:mod:`oilwatch.monitoring.estimate`), the views
(:mod:`oilwatch.monitoring.views`) and the self-contained HTML report (:mod:`oilwatch.monitoring.report`)."""

OPERATING_POINTS = ("auto", "follow", "nominal")
"""``oilwatch estimate --operating-point`` choices (:class:`oilwatch.monitoring.estimate.EstimateOptions`),
here so that the command line is built without importing the estimator."""
