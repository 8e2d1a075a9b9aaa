"""Hydrodynamic journal bearing fed through one or more grooves: mass-conserving p-theta film, coefficients.

Modules (import from them directly; this package imports nothing, to keep ``models`` light):

* :mod:`.geometry` ``JournalBearing`` (Table 3) and its groove layout (``AxialGroove``);
* :mod:`.grid` ``Mesh``, ``PRODUCTION_MESH`` and the angle convention (groove "0 deg" at the top,
  opposite the load, angles in the direction of rotation);
* :mod:`.supply` ``SupplyFlow(q_m3_s)`` / ``SupplyPressure(p_pa)``;
* :mod:`.film` ``solve_film(bearing, speed_hz, eccentricity_m, supply, velocity_m_s, mesh)`` (semi-smooth
  Newton) and the squeeze-term treatment; :mod:`.gauss_seidel` the plain Gauss-Seidel reference;
* :mod:`.equilibrium` ``static_equilibrium``, ``linearized_coefficients``, ``coefficients_at``
  (Lund's convention K_ij = -dF_i/dx_j, C_ij = -dF_i/dxdot_j);
* :mod:`.table` ``compute_table``, ``CoefficientTable`` (JSON, PCHIP interpolation over flowrate).
"""
