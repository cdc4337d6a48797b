"""A ground station's sticks, as ArduPilot Rover reads them: RC_CHANNELS_OVERRIDE and
MANUAL_CONTROL become override values on the radio's channels, and MANUAL mode reads its
steering and throttle from them.

lfctl's vehicles have no radio, so an override is the only pilot input. Its channels are
Rover's defaults: steering on channel 1 (``RCMAP_ROLL``), throttle on channel 3
(``RCMAP_THROTTLE``), each 1100-1900 us with its trim at 1500 (``RCn_MIN``, ``RCn_MAX``,
``RCn_TRIM``) and a dead zone of 30 us either side of the trim (``RCn_DZ``; Rover's default for
both, and its throttle channel is centred, so below the trim is reverse).

- RC_CHANNELS_OVERRIDE: channels 1-8 take any value but 65535 ("no change"); 0 releases the
  channel. Channels 9-16 ignore 0 and 65535 alike, and 65534 releases them; 17 and 18 are not
  read (Rover has 16 channels, ``NUM_RC_CHANNELS``: RC_CHANNELS reports them as 0).
- MANUAL_CONTROL: ``y`` (-1000..1000) drives the steering channel and ``z`` (-1000..1000) the
  throttle channel, both mapped linearly onto 1100..1900 us; 32767 (INT16_MAX) releases the
  channel.
- Both are taken only from system ``SYSID_MYGCS``, as Rover takes them; MANUAL_CONTROL only
  when its ``target`` is this vehicle, RC_CHANNELS_OVERRIDE when its ``target_system`` is this
  vehicle or 0 (as Rover's MAVLink routing passes it on).
- A channel reads as Rover's does: the pulse width as a signed 16-bit number, clipped to the end
  points, through the dead zone to a whole percent of throttle and a whole centidegree of
  steering (Rover's integer ``control_in``).
- An override lasts ``RC_OVERRIDE_TIME`` seconds after it last arrived (3 s by default; 0 turns
  overrides off, a negative value keeps them until released). A channel whose override has
  lapsed reads as centred. Rover, with no receiver, differs here: its radio failsafe
  (``FS_THR_ENABLE``, on by default) zeroes the sticks ``RC_FS_TIMEOUT`` after the last RC
  frame and takes ``FS_ACTION``, and with it off the last sticks stay in force. lfctl models no
  radio failsafe and stops, the safer of the two.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = [
    "RADIO_MAX",
    "RADIO_MIN",
    "RADIO_TRIM",
    "RC_DEAD_ZONE",
    "STEER_CHANNEL",
    "STEER_RANGE",
    "THROTTLE_CHANNEL",
    "THROTTLE_RANGE",
    "PilotInput",
    "RcOverrides",
    "manual_to_pwm",
    "stick",
]

#: Rover's default input range, trim and dead zone for the steering and throttle channels, us
RADIO_MIN, RADIO_TRIM, RADIO_MAX = 1100, 1500, 1900
RC_DEAD_ZONE = 30
#: Rover's default channel map (1-based, as RCMAP_ROLL and RCMAP_THROTTLE)
STEER_CHANNEL, THROTTLE_CHANNEL = 1, 3
#: the range of Rover's control_in on its throttle (percent) and steering (centidegrees) channels
THROTTLE_RANGE, STEER_RANGE = 100, 4500
#: the channels RC_CHANNELS carries
N_CHANNELS = 18
#: the channels a Rover has, and reads of an RC_CHANNELS_OVERRIDE (NUM_RC_CHANNELS)
ROVER_CHANNELS = 16
UINT16_MAX = 65535
INT16_MAX = 32767


@dataclass(frozen=True)
class PilotInput:
    """The sticks MANUAL reads, each -1..1 (Rover's control_in over its full range):
    ``steering`` positive turns clockwise seen from above, ``throttle`` positive drives forward.
    ``active`` is False when neither channel holds a live override (no pilot: centred sticks)."""

    steering: float
    throttle: float
    active: bool


def stick(pwm: int, steps: int = THROTTLE_RANGE) -> float:
    """A centred channel's position, -1..1, from its pulse width, as Rover's
    ``pwm_to_angle_dz_trim`` reads it: the width as a signed 16-bit number (65535 is -1),
    clipped to the end points, 0 inside the dead zone, then linear out to the end points in
    whole steps (truncated toward zero).

    Parameters
    ----------
    pwm : int
        The channel's pulse width, us.
    steps : int
        The channel's range in Rover's units: :data:`THROTTLE_RANGE` (whole percent) or
        :data:`STEER_RANGE` (centidegrees).
    """
    width = min(RADIO_MAX, max(RADIO_MIN, (int(pwm) + 0x8000) % 0x10000 - 0x8000))
    high, low = RADIO_TRIM + RC_DEAD_ZONE, RADIO_TRIM - RC_DEAD_ZONE
    if width > high:
        return int(steps * (width - high) / (RADIO_MAX - high)) / steps
    if width < low:
        return int(steps * (width - low) / (low - RADIO_MIN)) / steps
    return 0.0


def manual_to_pwm(value: int) -> int:
    """A MANUAL_CONTROL axis (-1000..1000) as the pulse width Rover's ``manual_override`` gives
    it: linear over 1100..1900 us (values beyond the axis' range go beyond the end points, and
    :func:`stick` clips them).

    Parameters
    ----------
    value : int
        The axis.
    """
    return int(RADIO_MIN + (RADIO_MAX - RADIO_MIN) * (value + 1000) / 2000)


class RcOverrides:
    """The override on each of the 18 channels: its pulse width and when it arrived."""

    def __init__(self) -> None:
        self._values: dict[int, tuple[int, float]] = {}  # channel (1-based) -> (us, t_s)

    def set(self, channel: int, pwm: int, t_s: float) -> None:
        """Hold ``pwm`` on ``channel`` (1-based) from ``t_s``.

        Parameters
        ----------
        channel : int
            The channel, 1-18.
        pwm : int
            The pulse width, us, kept modulo 65536 as Rover keeps it; 0 releases the channel.
        t_s : float
            When the override arrived, s.
        """
        pwm = int(pwm) & 0xFFFF  # Rover keeps an override as a uint16_t (a negative one wraps)
        if pwm == 0:
            self._values.pop(channel, None)
        else:
            self._values[channel] = (pwm, t_s)

    def clear(self) -> None:
        """Drop every override (Rover's ``RC_Channels::clear_overrides``, as a failsafe acts)."""
        self._values.clear()

    def from_rc_override(self, channels: list[int], t_s: float) -> None:
        """Take an RC_CHANNELS_OVERRIDE.

        Parameters
        ----------
        channels : list of int
            Its ``chan1_raw`` .. ``chan18_raw`` (the first 8 for MAVLink 1), us.
        t_s : float
            When it arrived, s.
        """
        for k, value in enumerate(channels[:ROVER_CHANNELS]):
            if k < 8:
                if value != UINT16_MAX:
                    self.set(k + 1, value, t_s)
            elif value not in (0, UINT16_MAX):
                self.set(k + 1, 0 if value == UINT16_MAX - 1 else value, t_s)

    def from_manual_control(self, y: int, z: int, t_s: float) -> None:
        """Take a MANUAL_CONTROL's steering and throttle axes.

        Parameters
        ----------
        y : int
            Its ``y`` axis, -1000..1000: the steering channel.
        z : int
            Its ``z`` axis, -1000..1000: the throttle channel.
        t_s : float
            When it arrived, s.
        """
        for channel, value in ((STEER_CHANNEL, y), (THROTTLE_CHANNEL, z)):
            self.set(channel, 0 if value == INT16_MAX else manual_to_pwm(value), t_s)

    def value(self, channel: int, t_s: float, timeout_s: float) -> int | None:
        """The live override on a channel, us, or None (none, released, or timed out).

        Parameters
        ----------
        channel : int
            The channel, 1-18.
        t_s : float
            Now, s.
        timeout_s : float
            How long an override lasts (``RC_OVERRIDE_TIME``): 0 takes none, a negative
            value keeps them until released.
        """
        held = self._values.get(channel)
        if held is None or timeout_s == 0 or not math.isfinite(timeout_s):
            return None
        pwm, since = held
        if timeout_s > 0 and t_s - since >= timeout_s:
            return None
        return pwm

    def values(self, t_s: float, timeout_s: float) -> list[int]:
        """Every channel's live override, us (0 where there is none), as RC_CHANNELS reports them.

        Parameters
        ----------
        t_s : float
            Now, s.
        timeout_s : float
            How long an override lasts, as in :meth:`value`.
        """
        return [self.value(k, t_s, timeout_s) or 0 for k in range(1, N_CHANNELS + 1)]

    def pilot(self, t_s: float, timeout_s: float) -> PilotInput:
        """The sticks MANUAL reads at ``t_s`` (a channel without a live override is centred;
        ``timeout_s`` as in :meth:`value`).

        Parameters
        ----------
        t_s, timeout_s : float
            As in :meth:`value`.
        """
        steer = self.value(STEER_CHANNEL, t_s, timeout_s)
        throttle = self.value(THROTTLE_CHANNEL, t_s, timeout_s)
        return PilotInput(
            steering=0.0 if steer is None else stick(steer, STEER_RANGE),
            throttle=0.0 if throttle is None else stick(throttle, THROTTLE_RANGE),
            active=steer is not None or throttle is not None,
        )
