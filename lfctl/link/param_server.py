"""The MAVLink parameter protocol over a table of :class:`~lfctl.link.params.Param`, answered
as ArduPilot answers it: the vehicle endpoint's parameters (component 1) and, on a real
rover, the companion's ``LFC_*`` (component 191) go through the same code."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.link.params import Param

__all__ = ["ParamServer", "param_text"]


def param_text(value: str | bytes) -> str:
    """A MAVLink char field as text (a parameter's name: up to 16 bytes, NUL-padded).

    Parameters
    ----------
    value : str or bytes
        The field as pymavlink gives it.
    """
    return (value.decode(errors="replace") if isinstance(value, (bytes, bytearray)) else str(value)).rstrip("\x00")


class ParamServer:
    """Answers PARAM_REQUEST_LIST, PARAM_REQUEST_READ and PARAM_SET over ``params``.

    A list gets every parameter with its index; a read by index or by exact name gets one (a
    read by name, index -1, as ArduPilot answers it); a set stores the value as ``AP_Param``
    stores it and is answered with the value in force, index -1, whether it was taken or not.
    An unknown name or index, a value outside the parameter's range and a read-only parameter
    are each said in a line of text (ArduPilot's own words for a read-only one).

    Parameters
    ----------
    params : dict of str to Param
        The table, in list order; its values change with each accepted set.
    send : callable
        Sends one MAVLink message.
    say : callable
        Sends a line of text (STATUSTEXT) with a MAV_SEVERITY.
    """

    def __init__(self, params: dict[str, Param], send: Callable[[Any], None], say: Callable[[str, int], None]) -> None:
        self.params = params
        self._send = send
        self._say = say

    def value_message(self, name: str, indexed: bool = True) -> Any:
        """PARAM_VALUE for ``name``: with its index in the list, or (``indexed`` False) index -1.

        Parameters
        ----------
        name : str
            A parameter of the table.
        indexed : bool
            Give its index (a list, a read by index) or -1 (a set, a read by name).
        """
        names = list(self.params)
        p = self.params[name]
        index = names.index(name) if indexed else 0xFFFF
        return mav.MAVLink_param_value_message(name.encode(), float(p.value), p.kind, len(names), index)

    def name_of(self, raw: str | bytes) -> str | None:
        """The parameter a request names: its exact name (ArduPilot's ``AP_Param`` finds a
        name only in its own case), or None.

        Parameters
        ----------
        raw : str or bytes
            The request's ``param_id``.
        """
        name = param_text(raw)
        return name if name in self.params else None

    def request_list(self) -> None:
        """Every parameter, in order (PARAM_REQUEST_LIST)."""
        for name in self.params:
            self._send(self.value_message(name))

    def request_read(self, m: Any) -> None:
        """One parameter, by index (``param_index`` >= 0) or by name (PARAM_REQUEST_READ).

        Parameters
        ----------
        m : pymavlink message
            The PARAM_REQUEST_READ.
        """
        names = list(self.params)
        if m.param_index >= 0:
            if m.param_index < len(names):
                self._send(self.value_message(names[m.param_index]))
            else:
                self._say(f"No parameter at index {m.param_index} (there are {len(names)})", mav.MAV_SEVERITY_WARNING)
            return
        name = self.name_of(m.param_id)
        if name is not None:
            self._send(self.value_message(name, indexed=False))
        else:
            self._say(f"Unknown parameter {param_text(m.param_id)}", mav.MAV_SEVERITY_WARNING)

    def set(self, m: Any) -> str | None:
        """Store a PARAM_SET's value if the parameter takes it, and answer with the value in
        force; returns the parameter's name when the value was stored.

        Parameters
        ----------
        m : pymavlink message
            The PARAM_SET.
        """
        name = self.name_of(m.param_id)
        if name is None:
            self._say(f"Unknown parameter {param_text(m.param_id)}", mav.MAV_SEVERITY_WARNING)
            return None
        p = self.params[name]
        taken = p.accepts(m.param_value)
        if taken:
            p.value = p.stored(m.param_value)
        elif p.readonly:
            self._say(f"Param write denied ({name})", mav.MAV_SEVERITY_WARNING)  # ArduPilot's text
        else:
            self._say(
                f"{name} rejected: {m.param_value:g} outside {p.lo:g}..{p.hi:g} {p.unit}".rstrip(),
                mav.MAV_SEVERITY_WARNING,
            )
        self._send(self.value_message(name, indexed=False))
        return name if taken else None
