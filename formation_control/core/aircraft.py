# Copyright 2026 formation_control developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Real flight dynamics: each vehicle a JSBSim aircraft (``plant_backend: jsbsim``).

One ``jsbsim.FGFDMExec`` per vehicle, stepped at ``dt_integration``, inside the process that
integrates the fleet (the offline simulator or the plant node): no server. Every aircraft starts
trimmed in straight and level flight (gliders: in a steady glide) at the scenario's
``altitude`` and true ``airspeed``, at its initial place and heading of
:func:`scenario.initial_state`, mapped to geodetic coordinates around ``geodetic_origin``.

**The map frame.** x east, y north (m) on the plane tangent at ``geodetic_origin``: ``x = (lon
- lon0) R_E cos(lat0)``, ``y = (lat - lat0) R_N`` with the WGS 84 radii of curvature at lat0
(errors of order (d / 6400 km)^2 over a distance d). The state rows are those of
:mod:`models`: x, y; theta the **yaw** as an angle from east, counter-clockwise (``pi/2 -
psi``); omega its rate theta'; u, v the horizontal velocity through the air along and across
the yaw (m/s), so that ``(u + i v) e^{i theta} + wind`` is the ground velocity. The yaw, not the
course, is the particle's theta: in the particle model (1.4) theta is the heading through the
flow, and the flow adds to it. The altitude (above the ground) and the bank are reported beside
the state.

**Wind.** Each step every aircraft gets JSBSim's wind ``atmosphere/wind-north-fps``,
``-east-fps`` from the scenario's flowfield at its own place and time (set after the trim: the
trim is done in still air). With ``turbulence`` > 0 JSBSim's MIL-F-8785C model adds gusts of
that severity, seeded per aircraft from ``turbulence_seed`` (the same seed, the same run).

**The autopilot.** An aircraft takes what a guided autopilot mode takes: an airspeed and a
turn-rate demand (:func:`turn_demand`). The inner loop, this module's own for every aircraft
(:class:`Aircraft`), runs each step:

- bank from the coordinated-turn relation ``tan(phi) = V omega / g`` for the demanded turn rate
  omega at the true airspeed V, clipped to ``bank_limit``;
- roll: roll-rate demand ``(phi_cmd - phi) / turn_lag``, clipped to ``roll_rate_limit``, held by
  the ailerons (proportional on the roll-rate error, integral on the bank error); the rudder
  holds zero sideslip, and with an integral the air velocity along the yaw (v = 0: a steady
  sideslip of a degree, in the laws' view a course error, left the sgs126 1.7 % off the radius);
- pitch: powered aircraft hold the trim altitude with the elevator (a pitch demand from the
  altitude error, its integral and the climb rate) and the airspeed with the throttle;
  gliders hold the airspeed with the elevator and descend.

A bank that follows its demand with time constant ``turn_lag`` makes the turn rate lag its
demand the same way, ``omega' = (omega_cmd - omega) / turn_lag``; so the second-order laws'
angular acceleration a becomes the demand ``omega_cmd = omega + turn_lag a`` and the aircraft
turns as the second-order particle (1.3) would, within the bank and roll-rate limits.

**The laws' units.** The particle laws are written for unit speed (1.4). At airspeed V they
apply in units of length L and time T with ``L / T = V``: ``r / L``, ``f / V``, ``omega0 L``,
``K T``, ``kappa T``. The particle view at speed V (:func:`control.particle_view` with
``speed = V``) is the unit-speed view of the flow ``f / V`` with its speeds times V; phi and
phi' do not depend on the units, and the circular law's cross term sigma takes the factor
``1 / (L T)^2`` (:attr:`laws.Circular.cross_scale`, :func:`control.law_units`: L = R,
T = R / V for a circle of radius R). docs/aircraft.md derives it.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import lru_cache
import math
import os
from pathlib import Path
import re
from typing import Any, Protocol
from xml.etree import ElementTree

from formation_control.core import formations
from formation_control.core.errors import refuse as _fail, ScenarioError
from formation_control.core.flowfields import Flowfield
from formation_control.core.geometry import RealArray
from formation_control.core.models import ROW_OMEGA, ROW_THETA, ROW_U, ROW_V, ROW_X, ROW_Y
from formation_control.core.parameters import DEFAULTS, Scenario
from formation_control.core.vehicles import vehicle_model
import numpy as np

G = 9.80665                      # standard gravity (m/s^2)
FT = 0.3048                      # metres per foot
WGS84_A = 6378137.0              # semi-major axis (m)
WGS84_E2 = 6.69437999014e-3      # first eccentricity squared
GUST_W20 = {0: 0.0, 1: 15.0, 2: 15.0, 3: 30.0, 4: 30.0, 5: 45.0, 6: 45.0, 7: 45.0}
"""MIL-F-8785C wind speed at 20 ft (kt) of each turbulence severity (light, moderate, severe)."""
GLIDE_SETTLE = 60.0              # seconds a glider flies its speed hold to find its glide
MAX_OUTPUTS = 16                 # <output> elements of a model sent to /dev/null
LOG_KEPT = 100                   # JSBSim messages kept (the trim's reasons)
BACKEND = 'jsbsim'               # the plant_backend whose plant this module builds
CHANNELS = ('altitude', 'bank', 'airspeed_demand', 'turn_rate_demand')
"""What a run records of each aircraft beside the state: altitude above the ground (m), bank
(rad, right wing down positive) and the autopilot demand (m/s, rad/s) held over the period."""


class Flight(Protocol):
    """What flying one aircraft reads of a scenario (a :class:`scenario.Scenario` has it)."""

    @property
    def jsbsim_aircraft(self) -> str: ...                               # noqa: D102
    @property
    def altitude(self) -> float: ...                                    # noqa: D102
    @property
    def airspeed(self) -> float: ...                                    # noqa: D102
    @property
    def dt_integration(self) -> float: ...                              # noqa: D102
    @property
    def turbulence_seed(self) -> int: ...                               # noqa: D102
    @property
    def bank_limit(self) -> float: ...                                  # noqa: D102
    @property
    def roll_rate_limit(self) -> float: ...                             # noqa: D102
    @property
    def turn_lag(self) -> float: ...                                    # noqa: D102
    @property
    def turbulence(self) -> int: ...                                    # noqa: D102


@dataclass(frozen=True)
class Trimmed:
    """What a trim check flies (a Flight): the aircraft, altitude, airspeed and step."""

    jsbsim_aircraft: str
    altitude: float
    airspeed: float
    dt_integration: float
    turbulence_seed: int = 0
    bank_limit: float = 0.5
    roll_rate_limit: float = 0.5
    turn_lag: float = 0.5
    turbulence: int = 0


class AircraftError(ValueError):
    """The aircraft cannot fly the scenario (unknown model, failed trim); names the parameter."""


def _jsbsim() -> Any:
    """Return the jsbsim module, quiet, or raise AircraftError saying how to install it."""
    try:
        import jsbsim
    except ImportError:
        raise AircraftError("parameter 'plant_backend' = 'jsbsim' needs the jsbsim package: "
                            "pip install -c constraints.txt '.[aircraft]' (make setup)") from None
    jsbsim.FGJSBBase().debug_lvl = 0
    return jsbsim


def _said(fdm: Any) -> list[str]:
    """Return what JSBSim has logged in this thread (its messages, not printed)."""
    jsbsim = _jsbsim()
    logger = jsbsim.get_logger()
    if not hasattr(logger, 'said'):
        logger = _logger(jsbsim)
        jsbsim.set_logger(logger)
    return list(logger.said)


def _logger(jsbsim: Any) -> Any:
    """Return a JSBSim logger that keeps the last messages instead of printing them."""
    class Quiet(jsbsim.FGLogger):
        def __init__(self) -> None:
            super().__init__()
            self.said: list[str] = []

        def message(self, message: str) -> None:
            self.said.append(message)
            del self.said[:-LOG_KEPT]

    return Quiet()


@lru_cache(maxsize=1)
def flown(sc: Scenario) -> bool:
    """Return whether JSBSim aircraft are the plant (``plant_backend: jsbsim``)."""
    return sc.plant_backend == BACKEND


def installed() -> tuple[str, ...]:
    """Return the names of the aircraft models the jsbsim package ships, sorted."""
    root = Path(_jsbsim().get_default_root_dir()) / 'aircraft'
    return tuple(sorted(d.name for d in root.iterdir() if (d / f'{d.name}.xml').is_file()))


LENGTH_UNITS = {'FT': FT, 'M': 1.0, 'IN': 0.0254}
"""Metres per unit of a JSBSim length (``<wingspan unit="FT">``)."""


@lru_cache(maxsize=16)
def wingspan(name: str) -> float:
    """
    Return the wingspan of the JSBSim aircraft ``name`` (m), its ``metrics/wingspan``.

    Raises
    ------
    AircraftError
        The aircraft is not installed or gives no wingspan, naming ``jsbsim_aircraft``.

    """
    path = Path(_jsbsim().get_default_root_dir()) / 'aircraft' / name / f'{name}.xml'
    try:
        span = ElementTree.parse(path).find('metrics/wingspan')
    except (OSError, ElementTree.ParseError):
        span = None
    if span is None or span.get('unit', 'FT').upper() not in LENGTH_UNITS:
        raise AircraftError(f"parameter 'jsbsim_aircraft' = {name!r} is invalid: no wingspan "
                            f'in {path} (an aircraft of: {", ".join(installed())})')
    return float(span.text or 'nan') * LENGTH_UNITS[span.get('unit', 'FT').upper()]


def bank_for_turn(airspeed: RealArray | float, rate: RealArray | float) -> RealArray:
    """
    Return the bank of a coordinated turn at the turn rate ``rate``.

    Parameters
    ----------
    airspeed : float or array_like
        True airspeed V (m/s).
    rate : float or array_like
        Turn rate theta' (rad/s), counter-clockwise positive (the map frame's).

    Returns
    -------
    ndarray
        ``phi = -atan(V rate / g)`` (rad), right wing down positive: a left (counter-clockwise)
        turn banks left.

    """
    return -np.arctan(np.asarray(airspeed) * np.asarray(rate) / G)


def turn_demand(sc: Scenario, X: RealArray, U: RealArray) -> RealArray:
    """
    Return the autopilot demand for the law's inputs ``U``, as the vehicle sends it.

    Parameters
    ----------
    sc : scenario.Scenario
        Its model, airspeed and turn_lag.
    X : array_like, shape (6, N)
        The states the commands were computed from (omega: the measured yaw rate).
    U : array_like, shape (2, N)
        The law's inputs: row 1 the turn rate (first order, rad/s) or the angular
        acceleration a (second order, rad/s^2).

    Returns
    -------
    ndarray, shape (2, N)
        Airspeed (m/s) and turn rate (rad/s) demands: ``omega + turn_lag a`` for the second
        order (the module docstring), the law's rate for the first.

    """
    U = np.asarray(U, float)
    rate = U[1] if vehicle_model(sc.model).first_order else \
        np.asarray(X)[ROW_OMEGA] + sc.turn_lag * U[1]
    return np.stack([np.full(np.shape(rate), sc.airspeed), rate])


def law_input(sc: Scenario, omega: RealArray, demand: RealArray) -> RealArray:
    """
    Return the law's inputs an autopilot ``demand`` stands for: :func:`turn_demand` inverted.

    Parameters
    ----------
    sc : scenario.Scenario
        Its model and turn_lag.
    omega : array_like, shape (N,)
        The yaw rates the demands were computed from (rad/s).
    demand : array_like, shape (2, N)
        Airspeed (m/s) and turn rate (rad/s) demands.

    Returns
    -------
    ndarray, shape (2, N)
        Row 0 zero, row 1 the turn rate (first order) or ``(omega_cmd - omega) / turn_lag``.

    """
    rate = np.asarray(demand, float)[1]
    if not vehicle_model(sc.model).first_order:
        rate = (rate - np.asarray(omega, float)) / sc.turn_lag
    return np.stack([np.zeros(np.shape(rate)), rate])


def required_bank(sc: Scenario) -> float:
    """
    Return the largest bank a circle of the scenario needs in its uniform wind.

    Returns
    -------
    float
        (rad): on the circle the course turns at ``omega0 s`` with the ground speed s, and the
        yaw at ``omega0 s / g_k`` (:func:`control.particle_speed_terms`, the wind normalised
        by V); the bank is :func:`bank_for_turn` of that, its largest value over the headings.
        In still air ``tan(phi) = V^2 / (g R)``, ``R = 1/|omega0|``.

    """
    e = np.exp(1j * np.linspace(-np.pi, np.pi, 721))
    f = sc.flow_c / sc.airspeed
    s2 = abs(e + f) ** 2
    g = (1.0 + (f.conjugate() * e).real) / s2
    rate = abs(sc.omega0) * sc.airspeed * np.sqrt(s2) / g
    return float(np.max(abs(bank_for_turn(sc.airspeed, rate))))


def _radii(lat0: float) -> tuple[float, float]:
    """Return the meridian and prime-vertical radii of curvature (m) at latitude lat0 (rad)."""
    w = 1.0 - WGS84_E2 * math.sin(lat0) ** 2
    return WGS84_A * (1.0 - WGS84_E2) / w ** 1.5, WGS84_A / math.sqrt(w)


@dataclass(frozen=True)
class MapFrame:
    """The tangent plane at a geodetic origin: local map x, y (m) to and from lat, lon (rad)."""

    lat0: float
    lon0: float
    north: float
    east: float

    @classmethod
    def at(cls, origin: Sequence[float]) -> MapFrame:
        """Return the frame at ``origin`` = (latitude, longitude) in degrees."""
        lat0, lon0 = math.radians(origin[0]), math.radians(origin[1])
        rn, re = _radii(lat0)
        return cls(lat0, lon0, rn, re * math.cos(lat0))

    def geodetic(self, x: float, y: float) -> tuple[float, float]:
        """Return (lat, lon) (rad) of the map point (x, y) (m)."""
        return self.lat0 + y / self.north, self.lon0 + x / self.east

    def local(self, lat: float, lon: float) -> tuple[float, float]:
        """Return the map point (x, y) (m) of (lat, lon) (rad)."""
        return (lon - self.lon0) * self.east, (lat - self.lat0) * self.north


# Gains of the inner loop (SI, normalised surfaces), tuned on c172x and the gliders.
ROLL_P, ROLL_I = 2.0, 0.3        # aileron per rad/s of roll-rate error; per rad s of bank error
YAW_BETA = -2.0                  # rudder per rad of sideslip
YAW_SLIP_I = 1.0                 # rudder per rad s of the air velocity's angle across the yaw
TURN_I = 0.1                     # turn-rate demand per rad of turn-rate error integral (1/s)
PITCH_P, PITCH_Q = 2.0, 0.6      # elevator per rad of pitch error; per rad/s of pitch rate
PITCH_I = 0.2                    # elevator per rad s of pitch error
INT_MAX = 1.0                    # bound of the pitch and bank integrals (rad s): no wind-up
SPEED_INT_MAX = 20.0             # bound of the airspeed integral (m)
ALT_INT_MAX = 100.0              # bound of the altitude integral (m s)
ALT_P, ALT_I, ALT_D = 0.01, 0.001, 0.02   # pitch per m, per m s, per m/s of climb
SPEED_P, SPEED_I = 0.05, 0.01    # throttle per m/s, per m of airspeed error
GLIDE_P, GLIDE_I = 0.02, 0.002   # glider pitch per m/s, per m of airspeed error
GLIDE_PITCH_I = 1.0              # PITCH_I of the glide trim (glide_trim): finds the elevator
PITCH_MAX = math.radians(15.0)


@dataclass
class Holds:
    """The trim an aircraft's holds work around, and their integrators."""

    theta: float                 # pitch at trim (rad)
    elevator: float              # elevator command at trim (normalised)
    throttle: float              # throttle at trim; nan: a glider
    altitude: float              # altitude held (m), powered
    glider: bool = False         # no engine: the elevator holds the airspeed
    bank_int: float = 0.0        # integral of the bank error (rad s)
    alt_int: float = 0.0         # integral of the altitude error (m s)
    speed_int: float = 0.0       # integral of the airspeed error (m)
    pitch_int: float = 0.0       # integral of the pitch error (rad s)
    rate_int: float = 0.0        # integral of the turn-rate error (rad)
    slip_int: float = 0.0        # integral of the air velocity's angle across the yaw (rad s)
    pitch_i: float = PITCH_I     # elevator per rad s of pitch error


class Aircraft:
    """
    One JSBSim aircraft with its autopilot (the module docstring).

    Parameters
    ----------
    sc : scenario.Scenario
        jsbsim_aircraft, altitude, airspeed, the limits and turn_lag, dt_integration,
        turbulence, turbulence_seed.
    frame : MapFrame
        The map frame.
    x, y, theta : float
        Initial place (m) and yaw (rad) in the map frame.
    index : int
        The vehicle's index (0-based), for its turbulence seed.
    glide : tuple of float, optional
        (alpha, gamma, elevator) of a glider's steady glide (:func:`glide_trim`).

    """

    def __init__(self, sc: Flight, frame: MapFrame, x: float, y: float, theta: float,
                 index: int, glide: tuple[float, float, float] | None = None) -> None:
        self.sc: Flight = sc
        self.frame = frame
        self.fdm = fdm = _new_fdm(sc, index)
        lat, lon = frame.geodetic(x, y)
        fdm['ic/lat-geod-rad'], fdm['ic/long-gc-rad'] = lat, lon
        fdm['ic/psi-true-rad'] = 0.5 * math.pi - theta
        if glide is not None:
            fdm['ic/alpha-rad'], fdm['ic/gamma-rad'] = glide[0], glide[1]
            fdm['fcs/elevator-cmd-norm'] = glide[2]
        fdm.run_ic()
        if glide is None:
            _trim(fdm, sc)
        self.holds = Holds(fdm['attitude/theta-rad'], fdm['fcs/elevator-cmd-norm'],
                           fdm['fcs/throttle-cmd-norm'] if glide is None else math.nan,
                           fdm['position/h-agl-ft'] * FT, glide is not None)
        self.get, self.put = _nodes(fdm, READ), _nodes(fdm, WRITE)
        if sc.turbulence:
            fdm['atmosphere/turb-type'] = 3
            fdm['atmosphere/turbulence/milspec/severity'] = sc.turbulence
            fdm['atmosphere/turbulence/milspec/windspeed_at_20ft_AGL-fps'] = (
                GUST_W20[sc.turbulence] * 1852.0 / 3600.0 / FT)
        self.theta = theta

    def set_wind(self, wind: complex) -> None:
        """Set the wind (m/s, map frame: east + i north) JSBSim blows from now on."""
        self.fdm['atmosphere/wind-east-fps'] = wind.real / FT
        self.fdm['atmosphere/wind-north-fps'] = wind.imag / FT

    def place(self) -> tuple[float, float]:
        """Return the aircraft's map position (m)."""
        fdm = self.fdm
        return self.frame.local(fdm['position/lat-geod-rad'], fdm['position/long-gc-rad'])

    def step(self, airspeed: float, rate: float) -> None:
        """Run the autopilot for the demands (m/s, rad/s) and JSBSim for one step."""
        get, put, sc, h = self.get, self.put, self.sc, self.holds
        dt = sc.dt_integration
        v = get['vt'].get_double_value() * FT
        phi = get['phi'].get_double_value()
        limit = sc.bank_limit
        h.rate_int = min(max(h.rate_int + (rate + get['psidot'].get_double_value()) * dt,
                             -INT_MAX), INT_MAX)
        phi_cmd = min(max(-math.atan(v * (rate + TURN_I * h.rate_int) / G), -limit), limit)
        p_max = sc.roll_rate_limit
        p_cmd = min(max((phi_cmd - phi) / sc.turn_lag, -p_max), p_max)
        h.bank_int = min(max(h.bank_int + (phi_cmd - phi) * dt, -INT_MAX), INT_MAX)
        aileron = ROLL_P * (p_cmd - get['p'].get_double_value()) + ROLL_I * h.bank_int
        put['aileron'].set_double_value(min(max(aileron, -1.0), 1.0))
        psi = get['psi'].get_double_value()
        across = ((get['vn'].get_double_value() - get['wn'].get_double_value()) * math.sin(psi)
                  - (get['ve'].get_double_value() - get['we'].get_double_value()) * math.cos(psi))
        h.slip_int = min(max(h.slip_int + across * FT / v * dt, -INT_MAX), INT_MAX)
        rudder = YAW_BETA * get['beta'].get_double_value() + YAW_SLIP_I * h.slip_int
        put['rudder'].set_double_value(min(max(rudder, -1.0), 1.0))
        speed_err = airspeed - v
        h.speed_int = min(max(h.speed_int + speed_err * dt, -SPEED_INT_MAX), SPEED_INT_MAX)
        if h.glider:
            pitch = h.theta - GLIDE_P * speed_err - GLIDE_I * h.speed_int
        else:
            alt_err = h.altitude - get['h'].get_double_value() * FT
            h.alt_int = min(max(h.alt_int + alt_err * dt, -ALT_INT_MAX), ALT_INT_MAX)
            pitch = h.theta + ALT_P * alt_err + ALT_I * h.alt_int - (
                ALT_D * get['hdot'].get_double_value() * FT)
            throttle = h.throttle + SPEED_P * speed_err + SPEED_I * h.speed_int
            put['throttle'].set_double_value(min(max(throttle, 0.0), 1.0))
        pitch_err = min(max(pitch, -PITCH_MAX), PITCH_MAX) - get['theta'].get_double_value()
        h.pitch_int = min(max(h.pitch_int + pitch_err * dt, -INT_MAX), INT_MAX)
        elevator = h.elevator - PITCH_P * pitch_err - h.pitch_i * h.pitch_int + (
            PITCH_Q * get['q'].get_double_value())
        put['elevator'].set_double_value(min(max(elevator, -1.0), 1.0))
        self.fdm.run()

    def state(self) -> tuple[float, ...]:
        """Return the state column x, y, theta, omega, u, v, then the altitude (m) and bank."""
        fdm = self.fdm
        x, y = self.place()
        raw = 0.5 * math.pi - fdm['attitude/psi-rad']
        self.theta += math.remainder(raw - self.theta, 2.0 * math.pi)
        air = complex(fdm['velocities/v-east-fps'] - fdm['atmosphere/total-wind-east-fps'],
                      fdm['velocities/v-north-fps'] - fdm['atmosphere/total-wind-north-fps'])
        body = air * FT * complex(math.cos(self.theta), -math.sin(self.theta))
        return (x, y, self.theta, -fdm['velocities/psidot-rad_sec'], body.real, body.imag,
                fdm['position/h-agl-ft'] * FT, fdm['attitude/phi-rad'])


READ = {'vt': 'velocities/vtrue-fps', 'phi': 'attitude/phi-rad', 'p': 'velocities/p-rad_sec',
        'beta': 'aero/beta-rad', 'h': 'position/h-agl-ft', 'hdot': 'velocities/h-dot-fps',
        'theta': 'attitude/theta-rad', 'q': 'velocities/q-rad_sec',
        'psidot': 'velocities/psidot-rad_sec', 've': 'velocities/v-east-fps',
        'vn': 'velocities/v-north-fps', 'we': 'atmosphere/total-wind-east-fps',
        'wn': 'atmosphere/total-wind-north-fps', 'psi': 'attitude/psi-rad'}
WRITE = {'aileron': 'fcs/aileron-cmd-norm', 'rudder': 'fcs/rudder-cmd-norm',
         'elevator': 'fcs/elevator-cmd-norm', 'throttle': 'fcs/throttle-cmd-norm'}


def _nodes(fdm: Any, names: dict[str, str]) -> dict[str, Any]:
    """Return the property nodes of ``names`` (short name -> property path) of an FDM."""
    manager = fdm.get_property_manager()
    return {key: manager.get_node(path, True) for key, path in names.items()}


def _new_fdm(sc: Flight, index: int) -> Any:
    """Return a loaded FGFDMExec of the scenario's aircraft, dt and seed, before its ICs."""
    jsbsim = _jsbsim()
    fdm = jsbsim.FGFDMExec(None)
    _said(fdm)
    fdm.set_debug_level(0)
    if not fdm.load_model(sc.jsbsim_aircraft):
        raise AircraftError(f"parameter 'jsbsim_aircraft' = {sc.jsbsim_aircraft!r}: JSBSim "
                            f'could not load it')
    for n in range(MAX_OUTPUTS):                       # no files of the model's <output>s
        if not fdm.set_output_filename(n, os.devnull):
            break
    fdm.disable_output()
    fdm.set_dt(sc.dt_integration)
    fdm['atmosphere/randomseed'] = sc.turbulence_seed * 65537 + index
    fdm['ic/h-agl-ft'] = sc.altitude / FT
    fdm['ic/vt-fps'] = sc.airspeed / FT
    return fdm


def powered(fdm: Any) -> bool:
    """Return whether the loaded aircraft has an engine (else a glider)."""
    return bool(fdm.get_propulsion().get_num_engines() > 0)


def _trim(fdm: Any, sc: Flight) -> None:
    """Trim a powered aircraft in straight and level flight, or raise AircraftError."""
    fdm['propulsion/set-running'] = -1
    heard = len(_said(fdm))
    try:
        fdm['simulation/do_simple_trim'] = 1
        return
    except RuntimeError:
        pass
    told = ' '.join(_said(fdm)[heard:])
    axes = re.findall(r"(\w+) doesn't appear to be trimmable", told) or ['the trim']
    raise AircraftError(
        f"parameter 'airspeed' = {sc.airspeed} m/s, 'altitude' = {sc.altitude} m: JSBSim "
        f'cannot trim {sc.jsbsim_aircraft} in straight and level flight there: '
        f"{', '.join(sorted(set(axes)))} not trimmable (no steady state with udot, wdot, "
        f'qdot = 0 within its throttle, elevator and angle of attack); try another airspeed '
        f'or altitude')


def glide_trim(sc: Flight) -> tuple[float, float, float]:
    """
    Return (alpha, gamma, elevator) of the steady glide of a glider at the scenario's airspeed.

    JSBSim's trim needs a throttle for udot; a glider's glide is found by flying its speed hold
    wings level for GLIDE_SETTLE seconds from a level start, and read off.
    """
    fdm = _new_fdm(sc, 0)
    fdm.run_ic()
    holds = Holds(fdm['attitude/theta-rad'], 0.0, math.nan, 0.0, True, pitch_i=GLIDE_PITCH_I)
    plane = Aircraft.__new__(Aircraft)
    plane.sc, plane.fdm, plane.holds = sc, fdm, holds
    plane.get, plane.put = _nodes(fdm, READ), _nodes(fdm, WRITE)
    for _ in range(int(GLIDE_SETTLE / sc.dt_integration)):
        plane.step(sc.airspeed, 0.0)
    alpha, gamma = fdm['aero/alpha-rad'], fdm['flight-path/gamma-rad']
    speed = fdm['velocities/vtrue-fps'] * FT
    if abs(speed - sc.airspeed) > 0.05 * sc.airspeed or not math.isfinite(alpha):
        raise AircraftError(
            f"parameter 'airspeed' = {sc.airspeed} m/s: the glider {sc.jsbsim_aircraft} finds "
            f'no steady glide there (its speed hold reached {speed:.3g} m/s after '
            f'{GLIDE_SETTLE:g} s)')
    return alpha, gamma, fdm['fcs/elevator-cmd-norm']


@lru_cache(maxsize=16)
def _checked(name: str, altitude: float, airspeed: float,
             dt: float) -> tuple[float, float, float] | None:
    """Return the glide of a glider, None for a powered aircraft that trims; else AircraftError."""
    if name not in installed():
        raise AircraftError(f"parameter 'jsbsim_aircraft' = {name!r} is invalid: the installed "
                            f"JSBSim aircraft are {', '.join(installed())}")
    sc = Trimmed(name, altitude, airspeed, dt)
    fdm = _new_fdm(sc, 0)
    if not powered(fdm):
        return glide_trim(sc)
    fdm.run_ic()
    _trim(fdm, sc)
    return None


def check_trim(sc: Scenario) -> None:
    """Refuse (AircraftError) an aircraft JSBSim does not have, or one that does not trim."""
    _checked(sc.jsbsim_aircraft, sc.altitude, sc.airspeed, sc.dt_integration)


DEMAND_MARGIN = 1.1
"""tan(bank) of the test turn over that of the steepest turn the circle needs (10 % more load)."""
TEST_LEVEL, TEST_SETTLE, TEST_HOLD = 5.0, 40.0, 20.0
"""Seconds a test flight (:func:`fly_demand`) flies level, settles in the turn, is read."""
AIRSPEED_BAND = 0.05
"""Share of the airspeed demand the airspeed held stays within (test flight and run verdict)."""
ALTITUDE_BAND = 30.0
"""Altitude error (m) a powered aircraft stays within: the c172x keeps 4 m in calm air and 11.5 m
in moderate turbulence (docs/aircraft.md); the test flight's altitude lost, the run's error."""
FULL_THROTTLE = 0.98             # throttle at which a held airspeed has no power left in reserve


@dataclass(frozen=True)
class Demand:
    """
    What an aircraft holds in a steady turn at a demand (:func:`fly_demand`).

    Attributes
    ----------
    bank : float
        Bank of the test turn (rad), :data:`DEMAND_MARGIN` steeper than the steepest one needed.
    rate : float
        Turn rate demanded (rad/s).
    airspeed : float
        Mean true airspeed (m/s) over the last :data:`TEST_HOLD` s.
    sink : float
        Mean rate of descent (m/s) over that span.
    altitude_lost : float
        Altitude lost (m) from the trim to the end of the test.
    throttle : float
        Mean throttle over that span (nan: a glider).

    """

    bank: float
    rate: float
    airspeed: float
    sink: float
    altitude_lost: float
    throttle: float


@lru_cache(maxsize=64)
def fly_demand(flight: Trimmed, bank: float) -> Demand:
    """
    Fly one aircraft from its trim into a steady turn at ``bank`` (rad; 0: straight) and read it.

    Wings level for TEST_LEVEL s, then the turn rate ``g tan(bank) / V`` demanded at the airspeed
    V for TEST_SETTLE + TEST_HOLD s under the autopilot of the runs (:class:`Aircraft`).
    """
    glide = _checked(flight.jsbsim_aircraft, flight.altitude, flight.airspeed,
                     flight.dt_integration)
    plane = Aircraft(flight, MapFrame.at((0.0, 0.0)), 0.0, 0.0, 0.0, 0, glide)
    fdm, dt = plane.fdm, flight.dt_integration
    rate = G * math.tan(bank) / flight.airspeed
    start = fdm['position/h-agl-ft'] * FT
    level, end = round(TEST_LEVEL / dt), round((TEST_LEVEL + TEST_SETTLE + TEST_HOLD) / dt)
    read = []
    for n in range(end):
        plane.step(flight.airspeed, rate if n >= level else 0.0)
        if n >= end - round(TEST_HOLD / dt):
            read.append((fdm['velocities/vtrue-fps'] * FT, -fdm['velocities/h-dot-fps'] * FT,
                         fdm['fcs/throttle-cmd-norm']))
    speed, sink, throttle = np.mean(read, axis=0)
    return Demand(bank, rate, float(speed), float(sink),
                  start - fdm['position/h-agl-ft'] * FT, math.nan if glide else float(throttle))


def check_demand(sc: Scenario) -> tuple[str, ...]:
    """
    Refuse an aircraft that cannot hold the airspeed in the steepest turn the formation needs.

    The test flight (:func:`fly_demand`) at :data:`DEMAND_MARGIN` times the tan(bank) of the
    circle (:func:`required_bank`; a parallel formation, whose only turns are those that
    gather it, at ``bank_limit``), within ``bank_limit``: refused if the
    airspeed held falls :data:`AIRSPEED_BAND` short of ``airspeed`` or a powered aircraft loses
    more than :data:`ALTITUDE_BAND`; warned if it holds the airspeed only at full throttle.
    """
    radius = formations.of(sc).radius(sc)
    bank = sc.bank_limit if radius is None else min(
        math.atan(DEMAND_MARGIN * math.tan(required_bank(sc))), sc.bank_limit)
    flight = Trimmed(sc.jsbsim_aircraft, sc.altitude, sc.airspeed, sc.dt_integration,
                     bank_limit=sc.bank_limit, roll_rate_limit=sc.roll_rate_limit,
                     turn_lag=sc.turn_lag)
    held = fly_demand(flight, bank)
    glider = math.isnan(held.throttle)
    circle = '' if radius is None else f", 'omega0' = {sc.omega0:.4g} (R = {radius:.4g} m)"
    where = (f"'jsbsim_aircraft' = {sc.jsbsim_aircraft!r} at 'airspeed' = {sc.airspeed} m/s, "
             f"'altitude' = {sc.altitude} m{circle}")
    turn = f'in a steady turn at bank {math.degrees(bank):.1f} deg ' + (
        "(bank_limit: the formation's turns while it gathers)" if radius is None else
        f"(the circle's steepest, tan(bank) {DEMAND_MARGIN - 1:.0%} steeper)")
    figures = f'{turn} it holds {held.airspeed:.1f} m/s' + (
        f' and sinks {held.sink:.2g} m/s' if glider else
        f' at throttle {held.throttle:.2f}, losing {held.altitude_lost:.1f} m in '
        f'{TEST_LEVEL + TEST_SETTLE + TEST_HOLD:g} s')
    remedy = 'a smaller bank_limit' if radius is None else 'a larger radius (smaller |omega0|)'
    short = held.airspeed < (1.0 - AIRSPEED_BAND) * sc.airspeed
    if short or (not glider and held.altitude_lost > ALTITUDE_BAND):
        raise ScenarioError(
            f'{where}: the aircraft cannot hold the demand: {figures}, beyond '
            f'{AIRSPEED_BAND:.0%} of the airspeed or {ALTITUDE_BAND:g} m of altitude: use another '
            f'airspeed, {remedy} or another aircraft')
    if not glider and held.throttle >= FULL_THROTTLE:
        return (f'{where}: the demand is marginal: {figures}, with no power in reserve',)
    return ()


LAGS = (0.5, 0.7, 1.0, 1.4, 2.0)
"""The bank-hold time constants ``turn_lag`` (s) :func:`identify` tries, fastest first."""
STEP_BANK = 0.8                  # the step's bank, a share of bank_limit: the laws' hardest turns
STEP_LEVEL, STEP_HOLD, STEP_FIT = 2.0, 20.0, 10.0   # s level, s in the turn, s of it fitted


@dataclass(frozen=True)
class TurnResponse:
    """
    An aircraft's turn rate after a step in its turn-rate demand (:func:`turn_response`).

    Attributes
    ----------
    turn_lag : float
        The bank-hold time constant flown (s).
    rate : float
        The turn rate demanded from the step on (rad/s).
    t, omega : ndarray, shape (n,)
        Time from the step (s) and the yaw rate (rad/s), every integration step.
    lag : float
        The first-order lag fitted to the first STEP_FIT s: the tau of least squares of
        ``omega - rate (1 - exp(-t / tau))`` (s).
    error : float
        The integral of ``|omega - rate| / rate`` over the STEP_HOLD s (s): 0 for a turn rate
        that follows its demand at once; an overshoot, a slow approach or an oscillation add.

    """

    turn_lag: float
    rate: float
    t: RealArray
    omega: RealArray
    lag: float
    error: float


@lru_cache(maxsize=64)
def turn_response(flight: Trimmed) -> TurnResponse:
    """
    Fly one aircraft from its trim through a step in its turn-rate demand and fit its lag.

    STEP_LEVEL s wings level, then STEP_HOLD s of the turn rate ``g tan(b) / V`` of the bank
    ``b = STEP_BANK bank_limit`` under the runs' autopilot (:class:`Aircraft`) with
    ``turn_lag`` of ``flight``.
    """
    glide = _checked(flight.jsbsim_aircraft, flight.altitude, flight.airspeed,
                     flight.dt_integration)
    plane = Aircraft(flight, MapFrame.at((0.0, 0.0)), 0.0, 0.0, 0.0, 0, glide)
    dt = flight.dt_integration
    rate = G * math.tan(STEP_BANK * flight.bank_limit) / flight.airspeed
    for _ in range(round(STEP_LEVEL / dt)):
        plane.step(flight.airspeed, 0.0)
    omega = []
    for _ in range(round(STEP_HOLD / dt)):
        plane.step(flight.airspeed, rate)
        omega.append(-plane.fdm['velocities/psidot-rad_sec'])
    w, t = np.array(omega), dt * np.arange(1, len(omega) + 1)
    fit = t <= STEP_FIT
    taus = np.arange(0.05, STEP_FIT, 0.01)
    cost = ((w[fit] - rate * (1.0 - np.exp(-t[fit] / taus[:, None]))) ** 2).sum(axis=1)
    error = float(np.sum(abs(w - rate)) * dt / rate)
    return TurnResponse(flight.turn_lag, rate, t, w, float(taus[np.argmin(cost)]), error)


def identify(sc: Scenario) -> TurnResponse:
    """
    Return the turn response of the bank hold of :data:`LAGS` the aircraft follows best.

    Each ``turn_lag`` of LAGS (:func:`turn_response`) at the scenario's aircraft, altitude,
    airspeed and limits; the one of the least ``error``.
    """
    return min((turn_response(Trimmed(sc.jsbsim_aircraft, sc.altitude, sc.airspeed,
                                      sc.dt_integration, bank_limit=sc.bank_limit,
                                      roll_rate_limit=sc.roll_rate_limit, turn_lag=lag))
                for lag in LAGS), key=lambda response: response.error)


def tuned(sc: Scenario) -> Scenario:
    """
    Return the scenario with the aircraft's own turn_lag and kappa where they are left out.

    With ``plant_backend: jsbsim`` and ``turn_lag`` 0: the identified bank hold
    (:func:`identify`), and kappa ``1 / turn_lag`` if kappa is at its default (the
    backstepping rate loop as fast as the bank follows, docs/aircraft.md). Unchanged otherwise,
    and where the aircraft cannot be flown at all (:func:`check` refuses it).
    """
    if not flown(sc) or sc.turn_lag or min(sc.airspeed, sc.altitude) <= 0.0:
        return sc
    try:
        lag = identify(sc).turn_lag
    except AircraftError:
        return sc
    return replace(sc, turn_lag=lag, kappa=1.0 / lag if sc.kappa == DEFAULTS.kappa else sc.kappa)


HOLD_SHARE = 0.5
"""Share of a run, at its end, over which the aircraft must have held airspeed and altitude."""


def held(sc: Scenario, t: RealArray, X: RealArray, altitude: RealArray) -> dict[str, Any]:
    """
    Return the airspeed and altitude a run's aircraft held, and the bands they left.

    Parameters
    ----------
    sc : scenario.Scenario
        Its airspeed, altitude and aircraft (a glider descends: its altitude is not held).
    t : array_like, shape (T,)
        Sample times (s).
    X : array_like, shape (T, 6, N) or (T, 6, B, N)
        The recorded states: the airspeed is the horizontal air velocity ``|u + i v|``.
    altitude : array_like, shape (T, N) or (T, B, N)
        The recorded altitudes (m).

    Returns
    -------
    dict
        Over the last :data:`HOLD_SHARE` of the run, from ``hold_from`` (s): ``airspeed_held``
        and ``altitude_held``, [min, max] over time and vehicles (m/s, m; per fleet of a
        batch); ``holds``, whether both stayed in their bands (``airspeed``:
        :data:`AIRSPEED_BAND` of ``airspeed``; ``altitude``, powered aircraft:
        :data:`ALTITUDE_BAND` of ``altitude``); for one run ``flight_unmet``, the names of
        the bands left, and ``flight``, how, in words.

    """
    t = np.asarray(t, float)
    keep = t >= t[-1] - HOLD_SHARE * (t[-1] - t[0])
    X, h = np.asarray(X, float)[keep], np.asarray(altitude, float)[keep]
    glider = _checked(sc.jsbsim_aircraft, sc.altitude, sc.airspeed, sc.dt_integration) is not None
    spans = {'airspeed': (np.hypot(X[:, ROW_U], X[:, ROW_V]), sc.airspeed,
                          AIRSPEED_BAND * sc.airspeed, 'm/s'),
             'altitude': (h, sc.altitude, math.inf if glider else ALTITUDE_BAND, 'm')}
    out: dict[str, Any] = {'hold_from': float(t[keep][0]), 'holds': True}
    unmet, why = [], []
    for name, (value, target, band, unit) in spans.items():
        low, high = np.min(value, axis=(0, -1)), np.max(value, axis=(0, -1))
        ok = np.maximum(target - low, high - target) <= band
        out[f'{name}_held'] = np.stack([low, high], axis=-1).tolist()
        out['holds'] = out['holds'] & ok
        if not np.all(ok):
            unmet.append(name)
            why.append(f'{name} {np.min(low):.4g}-{np.max(high):.4g} {unit} left {target:g} '
                       f'+- {band:.3g} {unit}')
    if np.ndim(out['holds']) == 0:
        out.update(holds=bool(out['holds']), flight_unmet=unmet, flight='; '.join(why))
    return out


def check(sc: Scenario) -> tuple[str, ...]:
    """
    Refuse a jsbsim scenario the aircraft cannot fly (docs/aircraft.md, "Bad input").

    A tangent plane within +-80 deg of latitude, airspeed limits that admit the airspeed, a
    circle within the bank limit, an aircraft JSBSim has and trims (:func:`check_trim`) and
    that holds the demand (:func:`check_demand`, which warns where it is marginal). Nothing
    for the native plant. The native plant's world and the rigid-body parameters, which
    JSBSim does not read, are refused by :func:`parameters.check_read`.
    """
    if not flown(sc):
        return ()
    if not -80.0 <= sc.geodetic_origin[0] <= 80.0:
        _fail('geodetic_origin', list(sc.geodetic_origin), 'the latitude must lie within '
              '+-80 deg (the map frame is a tangent plane)')
    for name, ok in (('min_airspeed', sc.min_airspeed <= sc.airspeed),
                     ('max_airspeed', not sc.max_airspeed or sc.max_airspeed >= sc.airspeed)):
        if not ok:
            _fail(name, getattr(sc, name), f'the limit must admit airspeed = {sc.airspeed} m/s')
    radius = formations.of(sc).radius(sc)
    if radius is not None:
        bank = required_bank(sc)
        if bank >= sc.bank_limit:
            _fail('omega0', sc.omega0, f'a circle of radius {radius:.4g} m at airspeed '
                  f'{sc.airspeed} m/s in the wind {list(sc.flow)} m/s needs a bank of '
                  f'{math.degrees(bank):.3g} deg (tan(bank) = V^2 / (g R) in still air), '
                  f'beyond bank_limit = {sc.bank_limit} rad = {math.degrees(sc.bank_limit):.3g} '
                  f'deg: use a larger radius (smaller |omega0|) or a larger bank_limit')
    try:
        check_trim(sc)
    except AircraftError as err:
        raise ScenarioError(str(err)) from None
    return check_demand(sc)


class Fleet:
    """
    The fleet of aircraft of a scenario, integrated with JSBSim.

    Parameters
    ----------
    sc : scenario.Scenario
        A scenario with ``plant_backend: jsbsim``.
    X0 : array_like, shape (6, N) or (6, B, N)
        Initial places and yaws (rows x, y, theta) of a fleet or of a batch of B fleets; the
        other rows come from the trim. Aircraft k of every fleet has the turbulence seed of
        index k: a run does not depend on the batch it is in.

    Attributes
    ----------
    X : ndarray, shape of X0
        The fleet's state (the module docstring).
    channels : dict of str to ndarray, shape ``X0.shape[1:]``
        Altitude (m), bank (rad) and the demands held (:data:`CHANNELS`).

    """

    def __init__(self, sc: Scenario, X0: RealArray) -> None:
        glide = _checked(sc.jsbsim_aircraft, sc.altitude, sc.airspeed, sc.dt_integration)
        frame = MapFrame.at(sc.geodetic_origin)
        X0 = np.asarray(X0, float)
        self.shape = X0.shape[1:]
        flat = X0.reshape(6, -1)
        self.sc, self.flow = sc, Flowfield(sc)
        self.planes = [Aircraft(sc, frame, flat[ROW_X, k], flat[ROW_Y, k], flat[ROW_THETA, k],
                                k % sc.num_vehicles, glide) for k in range(flat.shape[1])]
        self.demand = np.stack([np.full(len(self.planes), sc.airspeed),
                                np.zeros(len(self.planes))])
        self.X = np.zeros(X0.shape)
        self.channels: dict[str, RealArray] = {}
        self._read()
        self._blow(0.0)

    def _read(self) -> None:
        rows = np.array([plane.state() for plane in self.planes]).T
        self.X[:] = rows[:6].reshape((6,) + self.shape)
        for name, row in zip(CHANNELS, (rows[6], rows[7], self.demand[0], self.demand[1])):
            self.channels[name] = row.reshape(self.shape).copy()

    def _blow(self, t: float) -> None:
        """Set each aircraft's wind: the flow at its place at time t."""
        if self.flow.uniform:
            wind = [self.flow.value] * len(self.planes)
        else:
            xy = np.array([plane.place() for plane in self.planes]).T
            wind = list(np.broadcast_to(self.flow(t, xy[0], xy[1]), (len(self.planes),)))
        for plane, w in zip(self.planes, wind):
            plane.set_wind(complex(w))

    def hold(self, demand: RealArray) -> None:
        """Hold the demands (2, ...) of the state's shape: airspeed (m/s) and turn rate (rad/s)."""
        sc = self.sc
        self.demand = np.array(demand, float).reshape(2, -1)
        self.demand[0] = np.clip(self.demand[0], sc.min_airspeed, sc.max_airspeed or np.inf)
        self.channels['airspeed_demand'] = self.demand[0].reshape(self.shape).copy()
        self.channels['turn_rate_demand'] = self.demand[1].reshape(self.shape).copy()

    def advance(self, t: float, steps: int) -> RealArray:
        """Integrate ``steps`` steps from time t with the demands held; return the state."""
        airspeed, rate = self.demand.tolist()
        dt = self.sc.dt_integration
        for step in range(steps):
            if step and not self.flow.uniform:
                self._blow(t + step * dt)
            for plane, v, w in zip(self.planes, airspeed, rate):
                plane.step(v, w)
        if not self.flow.uniform:
            self._blow(t + steps * dt)
        self._read()
        return self.X.copy()
