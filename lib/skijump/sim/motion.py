"""Truth motion of a simulated ski jump: position, velocity, acceleration, attitude.

Frame: the hill frame of the ski-jumping paper (origin at the take-off edge,
x forward along the hill axis, y right, z down).  The simulated point is the
IMU (an arm-mounted phone).

Phases
------
1. Rest at the start gate (on the in-run straight), then the release: the
   jumper lets go of the bar over ``release_time`` (a septic smoothstep on the
   downhill force, so the motion starts smoothly).
2. In-run along the profile: ``s'' = g sin(beta) - mu N tanh(s'/v0) - k s'^2``
   with the normal force per mass ``N = g cos(beta) + s'^2 kappa``.  The
   sensor lies on the in-run profile up to the take-off edge (x = 0).
3. Take-off at the edge: the ground reaction of the table fades and a short
   jump impulse (a pulse normal to the table, peak ``push`` at ``push_peak``
   after the edge) lifts the jumper; aerodynamic drag and lift areas change from
   the in-run crouch to the flight position.
4. Flight as a point mass with gravity, drag ``-rho/(2m) C_D A |v| v``, lift
   ``rho/(2m) C_L A |v|^2`` perpendicular to ``v`` in the vertical plane (``v`` relative to the air:
   an optional headwind ``wind`` with sinusoidal gusts ``gust``), and a small lateral force.
5. Touch-down: the skis touch while the sensor (on the arm) is still some
   decimetres above the landing profile; the landing impact -- a pulse of
   normal deceleration peaking ``impact_peak`` after the touch-down (paper
   Figure A1) -- takes out the sensor's velocity towards the slope and sets it
   onto the profile.  The touch-down is the instant at which that pulse
   brings the sensor to rest exactly on the profile: height above the slope
   = (its approach speed) x (the pulse's centroid time).
6. Landing and out-run on the profile, lateral drift, braking on the flat
   out-run to a stop, rest.

Kinematic exactness
-------------------
Each phase is an ODE solved with DOP853 at tolerance 1e-12 (dense output), so
position, velocity and acceleration of the truth are consistent to ~1e-10,
and the attitude's body rate is the exact derivative of its Euler chain
(:mod:`sportfusion.skijump.sim.attitude`).  What a 100 Hz IMU can represent
is the limit: the specific force is made continuous at every junction and its
short features smooth on the 10 ms scale -- curvature jumps of the certified
profile (E2, P, L, U) are bridged by a correction of at most
``max_deviation`` (0.45 mm) vertically that is C2 at the junction and C5 at
its ends (:class:`ContactPath`), the take-off and landing pulses are even
functions of the time since their start, the landing continues the flight's
acceleration *and jerk* (in the landing path's curvilinear coordinates), and
take-off and touch-down fall on IMU sample times.  Integrating the noise-free
truth IMU with RK4 and linearly interpolated inputs (the smoother's scheme)
then reproduces the trajectory to 0.6-3.2 cm over a whole session (gate, jump,
stop and 3 s of rest) on every shipped hill, HS38 to HS210 (3 seeds each, and
16 seeds on the four smallest hills; ``bench/bench_sim_skijump.py``); the residual is the scheme's own error,
mostly the attitude's coning error under the arm's oscillations (a few
thousandths of a degree, which leaks gravity into the velocity).  A kink of
the acceleration (a jerk jump ``dj``) would cost ``dt^2 dj / 12`` of velocity
per occurrence: before the landing's jerk was matched and the bridge ends
made C5, a touch-down on a small hill's bridge left up to 8 cm of drift.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.sim.ode import EventSpec, solve_fixed
from sportfusion.sim.smooth import pulse_rise_for_peak, pulse_s, smoothstep, smoothstep_s
from sportfusion.skijump.sim.contact import ODE_STEP, STEP_PLAN, ContactPath, HillGeometry, cartesian, curvilinear


@dataclass
class MotionParams:
    """Jumper, air and timing parameters of the simulated jump (SI units)."""

    mass: float = 65.0  # jumper with equipment [kg]
    rho: float = 1.1  # air density [kg/m^3]
    mu: float = 0.03  # track/snow friction coefficient [-]
    cda_inrun: float = 0.23  # drag area in the in-run crouch [m^2]
    cda_flight: float = 0.55  # drag area in flight [m^2]
    cla_flight: float = 0.65  # lift area in flight [m^2]
    cda_outrun: float = 0.40  # drag area standing in the out-run [m^2]
    drag_time: float = 0.4  # crouch -> flight drag [s]
    lift_time: float = 0.7  # crouch -> flight lift [s]
    v_static: float = 0.3  # speed scale of Coulomb friction and braking near standstill [m/s]
    rest_before: float = 5.0  # at the gate before the release [s]
    release_time: float = 1.0  # letting go of the bar [s]
    rest_after: float = 3.0  # standing after the stop [s]
    push: float = 15.0  # peak of the take-off impulse [m/s^2]
    push_peak: float = 0.02  # its time after the edge [s]
    push_decay: float = 0.12  # its decay time [s]
    support_decay: float = 0.05  # fading of the table's support after the edge [s]
    side_acc: float = 0.2  # lateral force amplitude in flight [m/s^2]
    side_period: float = 2.5  # [s]
    side_phase: float = 0.0  # [rad]
    wind: float = 0.0  # headwind along the hill axis, blowing against the jump [m/s]
    gust: float = 0.0  # gust amplitude on top of it [m/s]
    gust_period: float = 1.5  # [s]
    gust_phase: float = 0.0  # [rad]
    impact_peak: float = 0.05  # the landing impact's peak after the touch-down [s]
    impact_decay: float = 0.15  # its decay time [s]
    settle_time: float = 0.3  # span of the small corrections of the settling [s]
    tangential_blend: float = 0.25  # flight -> snow tangential force blend [s]
    attitude_blend: float = 0.6  # body pitch: table -> flight path, flight path -> slope [s]
    lateral_shift: float = 1.5  # lateral S-curve in the out-run [m]
    brake_ramp: float = 10.0  # distance over which braking builds up [m]
    stop_fraction: float = 0.85  # fraction of the flat out-run used to stop [-]
    dt: float = 0.01  # truth/IMU sample interval [s]
    # the landing continues the flight's jerk (no kink in the 100 Hz samples of the paper mode); the full
    # physics (1 kHz, an impact is a kink) leaves it: the jerk's finite differences of the profile spline's third
    # derivative carry its last bits, which differ between scipy releases, into 1e-4 of the landing
    match_jerk: bool = True


# ----------------------------------------------------------------------------- landing settle
def pulse_moments(t_peak: float, tau_d: float) -> tuple[float, float]:
    """Area [s] and centroid time [s] of the unit-peak impact pulse peaking at ``t_peak``."""
    from scipy.integrate import quad

    tau_r = pulse_rise_for_peak(t_peak, tau_d)
    end = 10 * tau_d
    area = quad(lambda s: pulse_s(s, tau_r, tau_d), 0, end, epsabs=1e-15, epsrel=1e-13, limit=400)[0]
    first = quad(lambda s: s * pulse_s(s, tau_r, tau_d), 0, end, epsabs=1e-15, epsrel=1e-13, limit=400)[0]
    return area, first / area


class Settle:
    """Normal acceleration of the sensor while it settles onto the landing profile.

    ``d''(tau) = (a0 + j0 tau) exp(-(tau/ta)^2) + A pulse(tau) + c2 B2(tau) + c3 B3(tau)``
    with ``A = -v0 / area(pulse)`` (the impact takes out the approach speed
    ``v0``), ``B2 = (1 - cos 2 pi u) / 2``, ``B3 = (cos pi u - cos 3 pi u) / 4``
    on ``u = tau / T`` in [0, 1]; ``c2, c3`` (small) bring the height above the
    profile and its rate to zero for good.  ``a0`` and ``j0`` continue the
    flight's normal acceleration and jerk, so the sensor's acceleration has no
    kink at the touch-down (a jerk jump ``dj`` costs the 100 Hz trapezoidal
    integration ``dt^2 dj / 12`` of velocity, several mm/s when the touch-down
    falls on a bridged curvature jump of a small hill); every other term is even
    at tau = 0 and the cosine terms also at T, so the sampled signal integrates
    accurately.
    """

    def __init__(
        self, d0: float, v0: float, a0: float, t_peak: float, tau_d: float, duration: float, j0: float = 0.0
    ) -> None:
        from scipy.integrate import quad

        self.a0, self.j0, self.T = float(a0), float(j0), float(duration)
        self.ta = 0.03
        self.tau_d = float(tau_d)
        self.tau_r = pulse_rise_for_peak(t_peak, self.tau_d)
        self.end = self.T + 8 * max(self.tau_d, self.ta)
        area, _ = pulse_moments(t_peak, self.tau_d)
        self.impact = -float(v0) / area
        self.c2 = self.c3 = 0.0

        def moments(fun: Callable[[float], float], end: float) -> tuple[float, float]:
            i0 = quad(fun, 0, end, epsabs=1e-15, epsrel=1e-13, limit=400)[0]
            i1 = quad(lambda s: s * fun(s), 0, end, epsabs=1e-15, epsrel=1e-13, limit=400)[0]
            return i0, i1

        # at rest on the profile for good: d'(inf) = v0 + int d'' = 0, d(inf) = d0 - int s d'' = 0
        # (the Gaussian tails of the fixed terms are below 1e-12 after 8 decay times)
        f0, f1 = moments(self.acc_s, self.end)
        m = np.array([moments(b, self.T) for b in (self._b2, self._b3)]).T
        self.c2, self.c3 = np.linalg.solve(m, np.array([-v0 - f0, d0 - f1]))

    def _b2(self, tau: float) -> float:
        return 0.5 * (1 - math.cos(2 * math.pi * tau / self.T)) if 0.0 <= tau <= self.T else 0.0

    def _b3(self, tau: float) -> float:
        u = tau / self.T
        return 0.25 * (math.cos(math.pi * u) - math.cos(3 * math.pi * u)) if 0.0 <= u <= 1.0 else 0.0

    def acc_s(self, tau: float) -> float:
        """d'' [m/s^2] at ``tau`` [s] after the touch-down."""
        if tau < 0.0:
            return 0.0
        out = (self.a0 + self.j0 * tau) * math.exp(-((tau / self.ta) ** 2))
        out += self.impact * pulse_s(tau, self.tau_r, self.tau_d)
        return out + self.c2 * self._b2(tau) + self.c3 * self._b3(tau)


# ----------------------------------------------------------------------------- the motion
@dataclass
class MotionTruth:
    """Truth on the sample grid (hill frame) and the jump's key figures.

    ``pitch``/``heading`` are the jumper frame's path (or flight-path) pitch and
    its direction of travel relative to the hill axis [rad], with their rates
    [rad/s]; ``clearance`` is the sensor's height above the profile along its
    normal [m] (the in-run profile up to the take-off, then the landing profile).
    """

    t: np.ndarray
    r: np.ndarray
    v: np.ndarray
    a: np.ndarray
    pitch: np.ndarray
    pitch_rate: np.ndarray
    heading: np.ndarray
    heading_rate: np.ndarray
    clearance: np.ndarray
    times: dict[str, float] = field(default_factory=dict)
    figures: dict[str, float] = field(default_factory=dict)


class JumpMotion:
    """Builds the truth motion of one jump; see the module text for the model."""

    def __init__(self, hill: HillGeometry, p: MotionParams, step: float = ODE_STEP) -> None:
        self.hill, self.p, self.g = hill, p, float(hill.g)
        self.step = float(step)  # the in-run's integration step [s] (coarser for the planning's candidates)
        self.inrun = ContactPath(hill.z_inrun, hill.x_start, 0.0, hill.inrun_junctions)
        self.landing = ContactPath(hill.z_landing, 0.0, hill.x_end, hill.landing_junctions)
        self.k_in = p.rho * p.cda_inrun / (2 * p.mass)
        self.k_out = p.rho * p.cda_outrun / (2 * p.mass)
        self.push_r = pulse_rise_for_peak(p.push_peak, p.push_decay)
        self.centroid = pulse_moments(p.impact_peak, p.impact_decay)[1]
        self.brake = 0.0
        self._solve_inrun()
        self._takeoff()

    # -- in-run ---------------------------------------------------------------
    def _inrun_xdd(self, tau: float, x: float, xd: float) -> float:
        p, g = self.p, self.g
        _, z1, z2 = self.inrun.zs(x)
        w = math.sqrt(1 + z1 * z1)
        v = xd * w
        normal = (g - xd * xd * z2) / w
        sdd = (
            g * z1 / w * smoothstep_s(tau / p.release_time)
            - p.mu * normal * math.tanh(v / p.v_static)
            - self.k_in * v * v
        )
        return (sdd - xd * xd * z1 * z2 / w) / w

    def _solve_inrun(self) -> None:
        def rhs(tau: float, y: tuple[float, ...]) -> tuple[float, float]:
            return y[1], self._inrun_xdd(tau, y[0], y[1])

        def edge(tau: float, y: tuple[float, ...]) -> float:
            return y[0]

        ev = EventSpec(edge, terminal=True, direction=1.0)
        sol = solve_fixed(rhs, (0.0, 120.0), [self.hill.x_start, 0.0], self.step, events=[ev])
        if sol.status != 1:
            raise InputError(
                f"the jumper does not reach the take-off edge from x = {self.hill.x_start:.1f} m; "
                "expected a start gate on the in-run"
            )
        self.inrun_sol = sol
        self.inrun_duration = float(sol.t_events[0][0])

    def _inrun_kin(self, tau: float, x: float, xd: float) -> tuple[tuple[float, ...], ...]:
        z0, z1, z2 = self.inrun.zs(x)
        xdd = self._inrun_xdd(tau, x, xd)
        return (x, 0.0, z0), (xd, 0.0, z1 * xd), (xdd, 0.0, z1 * xdd + z2 * xd * xd)

    # -- take-off and flight ----------------------------------------------------
    def _takeoff(self) -> None:
        """State at the edge, and the table's reaction that fades in flight (continuous specific force)."""
        tau = self.inrun_duration
        x, xd = self.inrun_sol.sol(tau)
        r, v, a = (np.array(q) for q in self._inrun_kin(tau, float(x), float(xd)))
        self.r_to, self.v_to = r, v
        f_in = a - np.array([0.0, 0.0, self.g])
        self.ground_to = f_in - np.array(self._aero(0.0, *v, 0.0))
        _, z1, _ = self.inrun.zs(float(r[0]))
        self.n_to = np.array([z1, 0.0, -1.0]) / math.hypot(1.0, z1)

    def _aero(self, tau: float, vx: float, vy: float, vz: float, cla: float) -> tuple[float, float, float]:
        p = self.p
        cda = p.cda_inrun + (p.cda_flight - p.cda_inrun) * smoothstep_s(tau / p.drag_time)
        cl = cla * smoothstep_s(tau / p.lift_time)
        # the air's velocity relative to the jumper: the headwind (and its gusts) adds to the forward speed
        vx = vx + p.wind + p.gust * math.sin(2 * math.pi * tau / p.gust_period + p.gust_phase)
        v2 = vx * vx + vy * vy + vz * vz
        speed = math.sqrt(v2)
        k = p.rho / (2 * p.mass)
        # lift: perpendicular to v, in the vertical plane through v, upwards
        lx, ly, lz = vz * vx / v2, vz * vy / v2, -1.0 + vz * vz / v2
        ln = math.sqrt(lx * lx + ly * ly + lz * lz)
        lift = k * cl * v2 / ln
        drag = -k * cda * speed
        return drag * vx + lift * lx, drag * vy + lift * ly, drag * vz + lift * lz

    def _flight_a(self, tau: float, vx: float, vy: float, vz: float, cla: float) -> tuple[float, float, float]:
        p = self.p
        ax, ay, az = self._aero(tau, vx, vy, vz, cla)
        support = math.exp(-((tau / p.support_decay) ** 2))
        push = p.push * pulse_s(tau, self.push_r, p.push_decay)
        side = (
            p.side_acc
            * (1 - math.exp(-((tau / 0.25) ** 2)))
            * math.cos(2 * math.pi * tau / p.side_period + p.side_phase)
        )
        gx, gy, gz = self.ground_to
        nx, ny, nz = self.n_to
        return (
            ax + support * gx + push * nx,
            ay + side + support * gy + push * ny,
            az + self.g + support * gz + push * nz,
        )

    def _solve_flight(self, cla: float, dense: bool) -> tuple[object, float]:
        def rhs(tau: float, y: tuple[float, ...]) -> tuple[float, ...]:
            return (y[3], y[4], y[5], *self._flight_a(tau, y[3], y[4], y[5], cla))

        def touch(tau: float, y: tuple[float, ...]) -> float:
            if tau < 0.2:
                return 1.0
            above = self.landing.zs(y[0])[0] - y[2]  # vertical height above the landing path [m]
            if above > 3.0:  # far above: the (costly) normal height is not needed for the sign
                return above
            d, d_rate = self.normal_state(y[0], y[2], y[3], y[5])
            return d + self.centroid * min(d_rate, 0.0)

        ev = EventSpec(touch, terminal=True, direction=-1.0)
        y0 = np.concatenate((self.r_to, self.v_to))
        sol = solve_fixed(rhs, (0.0, 30.0), y0, ODE_STEP if dense else STEP_PLAN, events=[ev])
        if sol.status != 1:
            raise InputError("the simulated flight never comes down to the landing profile; expected a landing")
        return sol, float(sol.t_events[0][0])

    def normal_state(self, x: float, z: float, vx: float, vz: float) -> tuple[float, float]:
        """Height above the landing profile [m] along its normal, and its rate [m/s], of a point in (x, z).

        Scalar Newton iterations on the path's polynomial (:meth:`ContactPath.zs`), as
        :meth:`ContactPath.foot` and :meth:`ContactPath.frame` do for arrays.
        """
        xp = float(x)
        for _ in range(8):
            z0, z1, z2 = self.landing.zs(xp)
            xp -= ((x - xp) + (z - z0) * z1) / (-1.0 - z1 * z1 + (z - z0) * z2)
        z0, z1, z2 = self.landing.zs(xp)
        w = math.sqrt(1.0 + z1 * z1)
        d = ((x - xp) * z1 - (z - z0)) / w
        n0, n1 = z1 / w, -1.0 / w
        c = z1 * z2 / w**3
        a0 = 1.0 + d * (z2 / w - z1 * c)
        a1 = z1 + d * c
        det = a0 * n1 - a1 * n0
        return d, (a0 * vz - a1 * vx) / det

    def _curvilinear_jerk(self, fsol: object, tau_f: float, h: float = 2e-3) -> tuple[float, float]:
        """Rates ``x_p'''`` [m/s^3] and ``d'''`` [m/s^3] of the flight's curvilinear accelerations at ``tau_f``.

        One-sided fourth-order differences (2 ms step) along the flight before the
        touch-down (foot point on the landing path and height above it; the
        flight ODE is solved by RK4 on 1 ms).  The landing continues both, so the
        sensor's acceleration has no kink at the touch-down.
        """
        cla = self.p.cla_flight

        def acc(tau: float) -> np.ndarray:
            y = fsol.sol(tau)  # type: ignore[attr-defined]
            a = np.array(self._flight_a(tau, *y[3:], cla))
            c = curvilinear(self.landing, y[[0, 2]], y[[3, 5]], a[[0, 2]])
            return np.array([c[2], c[5]])

        # fourth-order one-sided differences on a 2 ms step: a shorter step amplified the last bits of the
        # profile spline (which differ between scipy releases) into 1e-4 of the jerk
        f = [acc(tau_f - k * h) for k in range(5)]
        j = (25 * f[0] - 48 * f[1] + 36 * f[2] - 16 * f[3] + 3 * f[4]) / (12 * h)
        return float(j[0]), float(j[1])

    def length_for_lift(self, cla: float) -> float:
        """Jump length [m] (the skis' touch-down point along the landing profile) for a lift area [m^2]."""
        sol, _ = self._solve_flight(cla, dense=False)
        y = sol.y_events[0][0]
        xp, _ = self.landing.foot(np.array(y[0]), np.array(y[2]))
        return float(self.hill.jump_length(float(xp)))

    # -- landing and out-run -----------------------------------------------------
    def _landing_xdd(
        self, tau: float, xp: float, xpd: float, settle: Settle, e0: float, brake: float, e1: float = 0.0
    ) -> float:
        p, g = self.p, self.g
        _, z1, z2 = self.landing.zs(xp)
        w = math.sqrt(1 + z1 * z1)
        sd = xpd * w
        normal = g / w - sd * sd * z2 / w**3 + settle.acc_s(tau)
        stat = math.tanh(sd / p.v_static)
        sdd = (
            g * z1 / w
            - p.mu * normal * stat
            - self.k_out * sd * sd
            - brake * smoothstep_s((xp - self.hill.x_flat) / p.brake_ramp) * stat
            + (e0 + e1 * tau) * math.exp(-((tau / p.tangential_blend) ** 2))
        )
        return (sdd - xpd * xpd * z1 * z2 / w) / w

    def _solve_landing(  # noqa: ANN202
        self, xp0: float, xpd0: float, xpdd0: float, xpddd0: float, d0: float, dd0: float, settle: Settle
    ):
        """Landing ODE (foot point x_p, height d) from the touch-down to the stop.

        The blend ``(e0 + e1 tau) exp(-(tau / tangential_blend)^2)`` of the
        tangential force continues the flight's ``x_p''`` (``e0``) and ``x_p'''``
        (``e1``) at the touch-down.
        """
        p = self.p
        _, z1, z2 = self.landing.zs(xp0)
        w0 = math.sqrt(1 + z1 * z1)
        e0 = (xpdd0 - self._landing_xdd(0.0, xp0, xpd0, settle, 0.0, 0.0)) * w0  # x_p'' -> s''

        def xdd(h: float) -> float:  # along the path the landing should follow, without e1
            xp = xp0 + h * (xpd0 + h * (xpdd0 / 2 + h * xpddd0 / 6))
            return self._landing_xdd(h, xp, xpd0 + h * (xpdd0 + h * xpddd0 / 2), settle, e0, 0.0)

        hh = 2e-3  # fourth-order forward differences (as _curvilinear_jerk: robust to the last bits)
        if p.match_jerk:
            fx = [xdd(k * hh) for k in range(5)]
            e1 = (xpddd0 - (-25 * fx[0] + 48 * fx[1] - 36 * fx[2] + 16 * fx[3] - 3 * fx[4]) / (12 * hh)) * w0
        else:
            e1 = 0.0
        x_goal = self.hill.x_flat + p.stop_fraction * (self.hill.x_end - self.hill.x_flat)

        def solve(brake: float, dense: bool, until: float = np.inf):  # noqa: ANN202
            def rhs(tau: float, y: tuple[float, ...]) -> tuple[float, ...]:
                return y[1], self._landing_xdd(tau, y[0], y[1], settle, e0, brake, e1), y[3], settle.acc_s(tau)

            def stop(tau: float, y: tuple[float, ...]) -> float:
                return y[1] - 1e-6

            def end(tau: float, y: tuple[float, ...]) -> float:
                return y[0] - min(until, self.hill.x_end)

            evs = [EventSpec(stop, terminal=True, direction=-1.0), EventSpec(end, terminal=True)]
            return solve_fixed(rhs, (0.0, 300.0), [xp0, xpd0, d0, dd0], ODE_STEP if dense else STEP_PLAN, events=evs)

        # braking: the speed at the flat out-run without braking, then the deceleration that
        # stops the jumper near the goal (raised while it would overshoot the out-run)
        coast = solve(0.0, dense=False, until=self.hill.x_flat)
        v_flat = float(coast.y[1, -1]) if coast.t_events[1].size else 0.0
        room = max(x_goal - self.hill.x_flat - 0.5 * p.brake_ramp, 5.0)
        brake = max(v_flat**2 / (2 * room) - p.mu * self.g, 0.5)
        for _ in range(12):
            sol = solve(brake, dense=True)
            if sol.t_events[0].size:
                break
            brake *= 1.5
        else:
            raise InputError("the simulated jumper cannot stop within the out-run; expected a longer out-run")
        self.brake = brake
        return sol, float(sol.t_events[0][0]), e0, e1

    def _lateral(self, t_td: float, y0: float, v0: float, a0: float, t_stop: float):  # noqa: ANN202
        """Lateral position after touch-down: the flight's drift fades, then an S-curve in the out-run."""
        p = self.p
        tau_y = 1.0
        y_inf = y0 + 0.5 * v0 * tau_y
        t1 = t_td + tau_y + 0.5
        dur = max(0.5, min(3.0, t_stop - 1.5 - t1))

        def lat(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            tau = t - t_td
            s, s1, s2 = smoothstep(tau / tau_y)
            s1, s2 = s1 / tau_y, s2 / tau_y**2
            tay = y0 + v0 * tau + 0.5 * a0 * tau**2
            tay1 = v0 + a0 * tau
            y = tay * (1 - s) + y_inf * s
            y1 = tay1 * (1 - s) + (y_inf - tay) * s1
            y2 = a0 * (1 - s) - 2 * tay1 * s1 + (y_inf - tay) * s2
            c, c1, c2 = smoothstep((t - t1) / dur)
            sh = p.lateral_shift
            return y + sh * c, y1 + sh * c1 / dur, y2 + sh * c2 / dur**2

        return lat

    # -- the whole jump ---------------------------------------------------------
    def run(self) -> MotionTruth:
        """Simulate the whole session and sample it every ``dt`` from t = 0."""
        p, dt = self.p, self.p.dt
        k_to = int(math.ceil((p.rest_before + self.inrun_duration) / dt - 1e-9))
        t_to = k_to * dt
        t_rel = t_to - self.inrun_duration
        fsol, tau_c = self._solve_flight(p.cla_flight, dense=True)
        k_td = k_to + int(math.ceil(tau_c / dt - 1e-9))
        t_td = k_td * dt
        tau_f = t_td - t_to
        r_td, v_td = fsol.sol(tau_f)[:3], fsol.sol(tau_f)[3:]
        a_td = np.array(self._flight_a(tau_f, *v_td, p.cla_flight))
        xp0, xpd0, xpdd0, d0, dd0, ddd0 = curvilinear(self.landing, r_td[[0, 2]], v_td[[0, 2]], a_td[[0, 2]])
        xpddd0, dddd0 = self._curvilinear_jerk(fsol, tau_f) if p.match_jerk else (0.0, 0.0)
        settle = Settle(d0, dd0, ddd0, p.impact_peak, p.impact_decay, p.settle_time, dddd0)
        lsol, stop_rel, e0, e1 = self._solve_landing(xp0, xpd0, xpdd0, xpddd0, d0, dd0, settle)
        t_stop = t_td + stop_rel
        n = int(math.ceil((t_stop + p.rest_after) / dt)) + 1
        k = np.arange(n)
        t = k * dt
        r, v, a = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
        pitch, pitch_rate = np.zeros(n), np.zeros(n)
        heading, heading_rate = np.zeros(n), np.zeros(n)
        clearance = np.zeros(n)
        i_rest = t < t_rel
        i_in = (t >= t_rel) & (k < k_to)
        i_fl = (k >= k_to) & (k < k_td)
        i_la = (k >= k_td) & (t < t_stop)
        i_end = t >= t_stop
        # rest at the gate, in-run
        r[i_rest] = self._inrun_kin(0.0, self.hill.x_start, 0.0)[0]
        ys = self.inrun_sol.sol(t[i_in] - t_rel)
        for j, i in enumerate(np.flatnonzero(i_in)):
            r[i], v[i], a[i] = self._inrun_kin(t[i] - t_rel, ys[0, j], ys[1, j])
        on_in = i_rest | i_in
        z1 = self.inrun.z(r[on_in, 0], 1)
        pitch[on_in] = -np.arctan(z1)
        pitch_rate[on_in] = -self.inrun.z(r[on_in, 0], 2) * v[on_in, 0] / (1 + z1 * z1)
        clearance[on_in] = self.inrun.foot(r[on_in, 0], r[on_in, 2])[1]
        # flight
        tau = t[i_fl] - t_to
        yy = fsol.sol(tau)
        r[i_fl], v[i_fl] = yy[:3].T, yy[3:].T
        a[i_fl] = [self._flight_a(s, *vi, p.cla_flight) for s, vi in zip(tau, yy[3:].T, strict=True)]
        clearance[i_fl] = self.landing.foot(r[i_fl, 0], r[i_fl, 2])[1]
        # landing and out-run
        tau = t[i_la] - t_td
        ly = lsol.sol(tau)
        xpdd = np.array(
            [self._landing_xdd(s, y[0], y[1], settle, e0, self.brake, e1) for s, y in zip(tau, ly.T, strict=True)]
        )
        ddd = np.array([settle.acc_s(s) for s in tau])
        pxz, vxz, axz = cartesian(self.landing, ly[0], ly[1], xpdd, ly[2], ly[3], ddd)
        lat = self._lateral(t_td, r_td[1], v_td[1], a_td[1], t_stop)
        yl, ydl, yddl = lat(t[i_la])
        r[i_la] = np.stack((pxz[:, 0], yl, pxz[:, 1]), -1)
        v[i_la] = np.stack((vxz[:, 0], ydl, vxz[:, 1]), -1)
        a[i_la] = np.stack((axz[:, 0], yddl, axz[:, 1]), -1)
        clearance[i_la] = ly[2]
        # at rest after the stop
        ye = lsol.sol(stop_rel)
        pe, _, _ = cartesian(self.landing, ye[[0]], [0.0], [0.0], ye[[2]], [0.0], [0.0])
        r[i_end] = [pe[0, 0], lat(np.array([t_stop]))[0][0], pe[0, 1]]
        clearance[i_end] = ye[2]
        # jumper-frame pitch: the table's slope, blended into the flight-path angle after the
        # take-off, then (from the touch-down) into the landing profile's slope under the skis;
        # the blends keep the body from following the impulses of take-off and landing
        mov = i_fl | i_la
        vx, vy, vz = v[mov].T
        ax, ay, az = a[mov].T
        fp = np.arctan2(-vz, vx)
        fp_rate = (vz * ax - vx * az) / (vx * vx + vz * vz)
        heading[mov] = np.arctan2(vy, vx)
        heading_rate[mov] = (vx * ay - vy * ax) / (vx * vx + vy * vy)
        tb = p.attitude_blend
        s1, ds1, _ = smoothstep((t[mov] - t_to) / tb)
        table = -math.atan(self.inrun.zs(0.0)[1])
        pitch[mov] = (1 - s1) * table + s1 * fp
        pitch_rate[mov] = s1 * fp_rate + ds1 / tb * (fp - table)
        lnd = i_la | i_end
        xf = np.concatenate((ly[0], np.full(int(i_end.sum()), ye[0])))
        xfd = np.concatenate((ly[1], np.zeros(int(i_end.sum()))))
        z1, z2 = self.landing.z(xf, 1), self.landing.z(xf, 2)
        slope = -np.arctan(z1)
        slope_rate = -z2 * xfd / (1 + z1 * z1)
        th0, thd0 = pitch[k_td], pitch_rate[k_td]
        s2, ds2, _ = smoothstep((t[lnd] - t_td) / tb)
        lin = th0 + thd0 * (t[lnd] - t_td)
        pitch[lnd] = (1 - s2) * lin + s2 * slope
        pitch_rate[lnd] = (1 - s2) * thd0 + s2 * slope_rate + ds2 / tb * (slope - lin)
        far = np.flatnonzero((t >= t_td) & (np.abs(clearance) >= 1e-4))
        settled = float(t[far[-1] + 1]) if far.size and far[-1] + 1 < n else t_td
        times = {
            "release": t_rel,
            "takeoff": t_to,
            "touchdown": t_td,
            "settled": settled,
            "stop": t_stop,
            "end": float(t[-1]),
        }
        figures = {
            "jump_length": float(self.hill.jump_length(xp0)),
            "touchdown_x": xp0,
            "takeoff_speed": float(np.linalg.norm(self.v_to)),
            "touchdown_speed": float(np.linalg.norm(v_td)),
            "touchdown_clearance": d0,
            "touchdown_normal_speed": -dd0,
            "impact_peak": settle.impact,
            "flight_time": t_td - t_to,
            "stop_x": float(r[-1, 0]),
            "brake": self.brake,
        }
        return MotionTruth(t, r, v, a, pitch, pitch_rate, heading, heading_rate, clearance, times, figures)
