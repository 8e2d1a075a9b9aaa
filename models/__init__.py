"""oilwatch physics: the finite-element rotor, the fluid-film bearing and the rotor-bearing system.

Everything inside is in SI units. Nothing here imports from ``estimator``, ``fmu_src`` or ``oilwatch``.
"""

__version__ = "0.1.0"
