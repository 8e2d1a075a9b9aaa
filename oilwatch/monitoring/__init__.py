"""Monitoring a recorded machine: the estimator on a record (:mod:`oilwatch.monitoring.estimate`), the views
(:mod:`oilwatch.monitoring.views`) and the self-contained HTML report (:mod:`oilwatch.monitoring.report`)."""
