"""Which linearized film coefficients a machine's models use: its file's ``[bearings] dynamic_coefficients``.

A p-theta film's coefficients depend on the whirl frequency (:mod:`oilwatch.models.bearing.dynamic`): in the
cavitated zone the oil is carried by the Couette flow and lags the journal. ``"synchronous"`` tables hold
K(Omega), C(Omega) at whirl frequency = spin speed, the frequency of the unbalance response; a machine of
this kind takes its plant's and estimator's 1x response from them (close to the transient film's orbits,
where the quasi-static tables are tens of percent and degrees off) and its
free dynamics from the quasi-static table (constant synchronous coefficients destabilize the free modes:
:mod:`oilwatch.models.system.rotor_bearing`). ``"quasi-static"`` tables hold the held-partition stiffness and
the frozen-content ("full-film") damping of :func:`oilwatch.models.bearing.equilibrium.coefficients_at`, the
project's earlier default; a machine of that kind uses them for both.
"""

from __future__ import annotations

from ..validation import InputError

SYNCHRONOUS = "synchronous"
QUASI_STATIC = "quasi-static"
DEFAULT_KIND = SYNCHRONOUS
COEFFICIENT_KINDS = {
    SYNCHRONOUS: "frequency-dependent at whirl frequency = spin speed (models.bearing.dynamic: small-signal "
    "response of the transient p-theta film, fluid-fraction transport included, continuous time)",
    QUASI_STATIC: "quasi-static (held-partition stiffness; squeeze full-film: frozen film content)",
}
"""Each kind and what its tables' K, C are (stored in each table's ``solver.coefficients``)."""


def require_kind(kind: str, name: str = "dynamic coefficients") -> str:
    """``kind`` if it is one of :data:`COEFFICIENT_KINDS`, else :class:`InputError` naming ``name``."""
    if kind not in COEFFICIENT_KINDS:
        allowed = ", ".join(repr(k) for k in COEFFICIENT_KINDS)
        raise InputError(f"{name} must be one of {allowed}, got {kind!r}")
    return kind


def file_suffix(kind: str) -> str:
    """The table-file suffix of a kind: ``""`` for quasi-static (the older files), ``"_synchronous"``."""
    return "" if require_kind(kind) == QUASI_STATIC else f"_{kind}"


def table_kind(metadata: dict) -> str:
    """The kind of a table's coefficients from its metadata (``solver.coefficients``; absent: quasi-static,
    the tables written before the kinds existed); InputError for an unknown description."""
    description = metadata.get("solver", {}).get("coefficients")
    if description is None:
        return QUASI_STATIC
    for kind, text in COEFFICIENT_KINDS.items():
        if description == text:
            return kind
    raise InputError(f"unknown kind of bearing coefficients in a table: {description!r}")
