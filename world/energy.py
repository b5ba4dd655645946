"""Batteries and the electrical power of multirotors.

:class:`Battery` is a LiPo pack: state of charge (SOC) in [0, 1], terminal
voltage from a piecewise-linear open-circuit curve per cell, current drawn
from an electrical power (``I = P / V``), and constant-current charging at
the charger's voltage while docked (Narváez §V-A: a 12.6 V / 3.5 A charger
refilling the Bebop 2's 2700 mAh pack).

:class:`RotorPowerModel` gives the electrical power of a multirotor from its
thrust and air-relative velocity with momentum theory (formula in its
docstring), :class:`GroundPowerModel` that of a small wheeled robot.
:class:`BatteryGauge` is the battery-level sensor of a robot.

Units: A, V, W, mAh, s; SOC is a fraction (the gauge reports percent).
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from marsupial.api.readings import BatteryStatus

from .sensors.base import Sensor, SensorConfig

if TYPE_CHECKING:
    from .world import World

# Open-circuit voltage of one LiPo cell (V) against SOC, a typical 1C discharge curve:
# 4.20 V full, 3.30 V at the cut-off where the SOC is defined as 0.
LIPO_SOC = (0.0, 0.05, 0.10, 0.20, 0.30, 0.40, 0.50, 0.60, 0.70, 0.80, 0.90, 1.00)
LIPO_CELL_V = (3.30, 3.50, 3.60, 3.70, 3.75, 3.79, 3.83, 3.87, 3.92, 3.97, 4.07, 4.20)

AIR_DENSITY = 1.225  # kg/m^3, sea level, 15 °C
VOLTAGE_SOC_STEP = 1e-4  # the open-circuit voltage is re-read from the curve when the SOC moved this much


@dataclass(frozen=True)
class BatterySpec:
    """A battery pack and its charger.

    Attributes:
        capacity_mAh: rated capacity (Bebop 2: 2700 mAh, Narváez §V-A).
        cells: LiPo cells in series (3S: 12.6 V full).
        charge_current_A: constant charging current of the charger (3.5 A, §V-A).
        charge_voltage_V: charger voltage (12.6 V for 3S, §V-A); the pack is full at it.
    """

    capacity_mAh: float = 2700.0  # §V-A
    cells: int = 3
    charge_current_A: float = 3.5  # §V-A
    charge_voltage_V: float = 12.6  # §V-A

    def __post_init__(self) -> None:
        if self.capacity_mAh <= 0 or self.cells < 1 or self.charge_current_A < 0:
            raise ValueError(f"battery needs capacity_mAh > 0, cells >= 1, charge_current_A >= 0; got {self}")


class Battery:
    """State of a LiPo pack: SOC, voltage, current and the charge moved so far.

    Discharging: :meth:`draw` takes an electrical power (W) for ``dt`` seconds,
    the current is ``P / V(SOC)`` and the SOC falls by ``I dt / capacity``.
    Charging: :meth:`charge` pushes the charger's constant current (CC phase
    only) until the pack is full. ``current_A`` is positive when discharging
    and negative when charging.
    """

    def __init__(self, spec: BatterySpec, soc: float = 1.0):
        if not 0.0 <= soc <= 1.0:
            raise ValueError(f"initial state of charge must be within [0, 1], got {soc}")
        self.spec = spec
        self.soc = float(soc)
        self.current_A = 0.0
        self._voltage_soc = self.soc
        self._voltage = spec.cells * cell_voltage(self.soc)
        self._coulombs = spec.capacity_mAh * 3.6  # capacity in A·s
        self.discharged_mAh = 0.0
        self.charged_mAh = 0.0

    @property
    def voltage(self) -> float:
        """Open-circuit terminal voltage (V) at the present SOC (curve re-read every ``VOLTAGE_SOC_STEP``)."""
        if abs(self.soc - self._voltage_soc) >= VOLTAGE_SOC_STEP or self.soc in (0.0, 1.0):
            self._voltage_soc = self.soc
            self._voltage = self.spec.cells * cell_voltage(self.soc)
        return self._voltage

    @property
    def empty(self) -> bool:
        """True once the SOC reached the cut-off (0)."""
        return self.soc <= 0.0

    def draw(self, power_W: float, dt: float) -> None:
        """Discharge with ``power_W`` watts during ``dt`` seconds (no-op for zero power)."""
        if power_W <= 0.0 or self.soc <= 0.0:
            self.current_A = 0.0
            return
        current = power_W / self.voltage
        self.current_A = current
        self.soc = max(0.0, self.soc - current * dt / self._coulombs)
        self.discharged_mAh += current * dt / 3.6

    def charge(self, dt: float) -> None:
        """Charge at the charger's constant current during ``dt`` seconds, up to full."""
        if self.soc >= 1.0:
            self.current_A = 0.0
            return
        current = self.spec.charge_current_A
        self.current_A = -current
        self.soc = min(1.0, self.soc + current * dt / self._coulombs)
        self.charged_mAh += current * dt / 3.6

    def rest(self) -> None:
        """Neither charging nor discharging (current 0)."""
        self.current_A = 0.0


def cell_voltage(soc: float) -> float:
    """Open-circuit voltage (V) of one LiPo cell at state of charge ``soc`` in [0, 1]."""
    soc = min(1.0, max(0.0, soc))
    i = min(len(LIPO_SOC) - 1, max(1, bisect.bisect_right(LIPO_SOC, soc)))
    s0, s1 = LIPO_SOC[i - 1], LIPO_SOC[i]
    v0, v1 = LIPO_CELL_V[i - 1], LIPO_CELL_V[i]
    return v0 + (v1 - v0) * (soc - s0) / (s1 - s0)


@dataclass(frozen=True)
class RotorPowerModel:
    """Electrical power of a multirotor from momentum theory.

    ``P = [ T^1.5 / sqrt(2 ρ A) / FM  +  max(0, T v_z)  +  |F_drag · v_air| ] / η  +  P_avionics``

    - ``T`` total thrust (N), ``A`` total rotor disk area (m²), ``ρ`` air density:
      the first term is the induced (hover) power of an ideal rotor divided by
      the figure of merit ``FM`` (profile losses). At hover ``T = m g``.
    - ``T v_z`` the work of climbing (``v_z`` world vertical speed, m/s).
    - ``F_drag · v_air`` the parasitic power against air drag (grows with
      the cube of the airspeed for quadratic drag).
    - ``η`` the motor + ESC efficiency; ``P_avionics`` the flight computer,
      sensors and radio while the motors run.

    With the motors off the robot draws nothing (Narváez §V-B: zero energy
    while stored on the end effector).

    Calibration of the Bebop 2 (Narváez §V-B: "autonomy of 20 min", 2700 mAh 3S):
    the pack holds 2.7 Ah × 11.48 V mean open-circuit voltage = 31.0 Wh on
    :data:`LIPO_CELL_V`. Four 0.15 m rotors (A = 0.0707 m²) lifting 0.50 kg
    (T = 4.905 N) need ``T^1.5 / sqrt(2 ρ A)`` = 26.1 W of ideal induced power;
    with FM = 0.55 and η = 0.60 that is 79.1 W, plus 6 W avionics = 85.1 W,
    i.e. a 21.9 min hover (within the 20–25 min the vendor quotes). The
    AR.Drone 2.0 and Tello are calibrated the same way (see
    ``robots/quadrotor.py``: 12.1 and 13.2 min).
    """

    rotor_area_m2: float
    figure_of_merit: float
    drive_efficiency: float
    avionics_W: float
    air_density: float = AIR_DENSITY

    def __post_init__(self) -> None:
        if self.rotor_area_m2 <= 0 or not 0 < self.figure_of_merit <= 1 or not 0 < self.drive_efficiency <= 1:
            raise ValueError(f"rotor area > 0 and efficiencies within (0, 1] expected; got {self}")

    def power(self, thrust_N: float, climb_speed: float, drag_power_W: float) -> float:
        """Electrical power (W) for ``thrust_N``, climb speed (m/s) and parasitic drag power (W)."""
        induced = thrust_N**1.5 / math.sqrt(2.0 * self.air_density * self.rotor_area_m2) / self.figure_of_merit
        climb = thrust_N * climb_speed if climb_speed > 0.0 else 0.0
        return (induced + climb + abs(drag_power_W)) / self.drive_efficiency + self.avionics_W

    def hover_power(self, mass_kg: float, gravity: float = 9.81) -> float:
        """Electrical power (W) of a still hover of a ``mass_kg`` vehicle."""
        return self.power(mass_kg * gravity, 0.0, 0.0)


@dataclass(frozen=True)
class GroundPowerModel:
    """Electrical power of a small differential-drive robot.

    ``P = P_electronics + [P_drive_idle + C_rr m g |v|] / η``  while the wheels turn (``v`` or ``ω`` ≠ 0),
    ``P = P_electronics``  while they stand.

    - ``P_electronics``: the onboard computer and camera, always on.
    - ``P_drive_idle``: gear-motor and driver losses once the wheels turn (no-load current).
    - ``C_rr m g |v|``: the work against rolling resistance (``C_rr`` dimensionless, ``m`` kg, ``v`` m/s).
    - ``η``: the motor + gearbox + driver efficiency.

    Figures and their sources: ``robots/ugv_docking.py`` (:data:`CHILD_POWER`) and docs/world.md §6.
    """

    electronics_W: float
    drive_idle_W: float
    rolling_resistance: float
    drive_efficiency: float

    def __post_init__(self) -> None:
        efficiency_ok = 0 < self.drive_efficiency <= 1
        if min(self.electronics_W, self.drive_idle_W, self.rolling_resistance) < 0 or not efficiency_ok:
            raise ValueError(f"powers and C_rr >= 0 and an efficiency within (0, 1] expected; got {self}")

    def power(self, mass_kg: float, v: float, omega: float, gravity: float = 9.81) -> float:
        """Electrical power (W) of a ``mass_kg`` robot driving at ``v`` (m/s) and turning at ``omega`` (rad/s)."""
        if v == 0.0 and omega == 0.0:
            return self.electronics_W
        rolling = self.rolling_resistance * mass_kg * gravity * abs(v)
        return self.electronics_W + (self.drive_idle_W + rolling) / self.drive_efficiency


def hover_endurance_s(spec: BatterySpec, power_W: float, soc: float = 1.0, dt: float = 1.0) -> float:
    """Seconds a pack of ``spec`` starting at ``soc`` lasts at a constant ``power_W`` (integrated in ``dt`` steps).

    The current rises as the voltage sags, so this integrates the same
    :meth:`Battery.draw` the robots use rather than dividing energy by power.
    """
    if power_W <= 0:
        raise ValueError(f"power must be > 0 W, got {power_W}")
    battery = Battery(spec, soc)
    t = 0.0
    while not battery.empty:
        battery.draw(power_W, dt)
        t += dt
    return t


class BatteryGauge(Sensor[BatteryStatus]):
    """The battery-level sensor: SOC in percent (1 % steps, as vendor SDKs report), voltage, current.

    ``config.noise_std`` is the voltage noise (V); the SOC is quantised, not noisy.
    """

    def __init__(self, world: World, name: str, battery: Battery, config: SensorConfig):
        super().__init__(world, name, config)
        self.battery = battery

    def measure(self) -> BatteryStatus:
        b = self.battery
        noise = self.rng.normal(0.0, self.config.noise_std) if self.config.noise_std > 0 else 0.0
        return BatteryStatus(float(round(100.0 * b.soc)), b.voltage + noise, b.current_A)
