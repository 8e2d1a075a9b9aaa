"""OilFlowEKF as an FMI 3.0 co-simulation FMU: the FMI 2.0 slave behind a pythonfmu3 facade.

Variables, units, descriptions, checks and behaviour are those of ``fmu_src/oilwatch_ekf_slave.py``
(see :mod:`oilwatch.fmu_src.fmi3_shell`); nothing is declared here.
"""

from __future__ import annotations

from pythonfmu3 import Fmi3Slave

from oilwatch.fmu_src.fmi3_shell import Fmi3Shell
from oilwatch.fmu_src.oilwatch_ekf_slave import OilFlowEKF as Fmi2OilFlowEKF


# Fmi3Slave is named again because pythonfmu3's builder finds the slave class by a regular expression
# on this file's text ("class X(... Fmi3Slave ...)"), not by inheritance.
class OilFlowEKF(Fmi3Shell, Fmi3Slave):
    """FMI 3.0 shell of :class:`oilwatch.fmu_src.oilwatch_ekf_slave.OilFlowEKF`."""

    fmi2_slave = Fmi2OilFlowEKF
