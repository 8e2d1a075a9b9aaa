"""Errors of the co-simulation master: bad system descriptions and failing slaves."""

from __future__ import annotations

from oilwatch.models.validation import InputError


class SystemDescriptionError(InputError):
    """The system is wrong before any FMI call: a missing or corrupt FMU, an unknown variable, a
    connection naming a connector the FMU does not have, a bad step size."""


class SlaveError(RuntimeError):
    """An FMI call of a slave returned error, fatal or discard.

    Attributes: ``instance`` (the FMU instance name), ``call`` (the FMI function), ``time`` (the
    simulation time in s, None before initialization), ``status`` (the FMI status name) and
    ``log`` (the slave's last log messages, most recent last).
    """

    def __init__(self, instance: str, call: str, time: float | None, status: str, log: list[str]) -> None:
        when = "before the simulation started" if time is None else f"at t = {time:.9g} s"
        text = f"FMU instance '{instance}': {call} returned {status} {when}"
        if log:
            text += "; FMU log: " + " | ".join(line.replace("\n", " ") for line in log)
        super().__init__(text)
        self.instance = instance
        self.call = call
        self.time = time
        self.status = status
        self.log = log
