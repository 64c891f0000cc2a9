"""Settings of the whole-body solve (DESIGN.md, "Whole-body spacetime solve").

The weights of the objective's terms (:mod:`.costs`), the margins and slack prices of the
constraint rows (:mod:`.contacts`, :mod:`.zmp`, :mod:`.forces`, :mod:`.limits`,
:mod:`.collision`) and the SQP's stopping rules and trust region (:mod:`.sqp`): one small frozen
dataclass per concept, composed in :class:`WholeBodyConfig`::

    WholeBodyConfig(costs=CostWeights(accel=1.0), sqp=SqpOptions(iterations=5))

"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..core.checks import NonNegative, require_count, require_finite
from ..errors import OptionError
from .qp import SOLVERS


@dataclass(frozen=True)
class CostWeights(NonNegative):
    """Weights of the objective's terms (:mod:`.costs`; DESIGN.md, "Whole-body spacetime solve").

    Attributes:
        mesh: w_L, weight of the interaction-mesh (Laplacian) energy of the key points.
        direction: multiplies the key directions' weights.
        accel: w_a, weight of the squared second differences (at 30 fps) of the base and joint
            coordinates [per (m or rad)^2].
        damping: w_r, weight of |dq|^2 in every iteration.
        init: w_i, pull of the joints towards the initializer.
    """

    mesh: float = 1.0
    direction: float = 1.0
    accel: float = 3.0
    damping: float = 1e-3
    init: float = 1e-2


@dataclass(frozen=True)
class ZmpOptions(NonNegative):
    """The ZMP's cost and support-polygon rows (:mod:`.zmp`).

    Attributes:
        weight: w_z, weight of the squared distance of the ZMP beyond ``band_m`` from the
            desired ZMP (per axis) [1/m^2] in single support and in the double support
            within ``near_single_s`` of it.
        double_weight: w_z in the rest of double support (standing, the lead-in and
            lead-out, the middle of a walk's double support): the support polygon spans both
            soles there and the tracking controller has room on either; at 10 the cost leaned
            the trunk towards the middle of the stance (marker RMS of the walks and waves of
            docs/wholebody.md 5-13 mm higher, changelog).
        near_single_s: [s] double-support frames this close to a single-support frame keep
            ``weight``: with ``double_weight`` in all of double support the G1 wave was lost in
            the DART check 0.1 s after the landing of its lifted foot (2.8 s); at 0.3 s the
            walks gained less than 3 mm.
        band_m: a dead band around the desired ZMP [m]: a ZMP already within it costs nothing,
            so a balanced motion is left as it is.
        margin: the fraction of each sole's half length and half width kept free of the ZMP:
            the plan's support polygon is the hull of the soles shrunk about their centres by
            it, so the closed-loop controller of the physics check has room for feedback: the
            plan uses its polygon to the edge, and a controller corrects with the rest of the
            sole. The robot's trunk pays for it: it leans to hold the CoM over the inner part
            of a stance sole where the human's is not. On the 12 runs of docs/wholebody.md
            (with the `wbc` controller of 2026-12-03, 3 perturbed checks each) 0.6 stands all
            of them, as 0.7 did, with marker RMS 0.2-4.8 mm lower (the G1 and JVRC-1 waves
            61.7 -> 58.4, 65.6 -> 60.8 mm); at 0.5 the G1 wave is lost at 3.70 s. With earlier
            controllers 0.6 lost the HRP-4C walk (1.8 s) and at 0.4 no walk stood.
    """

    weight: float = 10.0
    band_m: float = 0.015
    margin: float = 0.6
    double_weight: float = 1.0
    near_single_s: float = 0.1

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.margin >= 1.0:
            raise OptionError("zmp margin", self.margin, "a fraction in [0, 1)")


@dataclass(frozen=True)
class SlackPrices(NonNegative):
    """Prices of the constraints' slack: exact penalties (above the multipliers of a feasible
    problem the slack is 0 where it can be).

    Attributes:
        balance: price per unit of the slack of the ZMP, normal-force, friction and torque rows
            [per m, per m/s^2 or per unit of the torque ratio].
        elastic: price per metre (or radian) of the slack of the sole, ground, acceleration and
            collision rows: a linearization that cannot put a sole on its footprint at once
            (the initializer far from it) still has a solution that moves towards it; at a
            feasible point the slack is 0.
    """

    balance: float = 1e3
    elastic: float = 1e4


#: Which contacts :class:`FootOptions` ``under_zmp`` moves.
UNDER_ZMP = ("slides", "all", "off")


@dataclass(frozen=True)
class FootOptions(NonNegative):
    """Heights the swing soles keep above the ground (:mod:`.contacts`).

    Attributes:
        clearance_m: swing-sole corners stay this high above the ground [m].
        swing_lift_m: over the middle third of a swing between two support phases of a foot,
            its ground points stay this high [m]: a step is a step (the evaluator, like a
            controller, tells phases apart by the sole leaving the ground).
        swing_edge_m: in every other frame of such a swing the ground points stay this high
            [m]: the sole leaves and lands flat instead of rolling over its toe or heel (the
            footprint model has no rolling contact).
        lift_off_m: but in the first frame of such a swing only this high [m]: a sole lifted
            20 mm within one 30-fps frame leaves at 0.6 m/s from rest, which a tracking
            controller's swing leg follows late (the JVRC-1 walk in the DART check: swing
            knee 82.6 mm off, and the late lift-off pushing the other sole 18.4 mm; at 10 mm:
            63.8 and 4.7, docs/checking.md). The plan's support phases say where the swing
            starts (``RobotMotion.contact_modes``), so the low sole is not read as support.
        under_zmp: a foot's contact whose single-support frames ask for a ZMP outside its
            sole is moved under it (:func:`imesh.solve.footprints.place_under_zmp`):
            ``"slides"`` only contacts that slide (MakeHuman's in-place zombie walk: marker
            RMS 142 -> 80 mm on G1), ``"all"`` every contact (moves footprints of the CMU
            walks, veer and wave by up to 110 mm: not measured on them yet), ``"off"``.
        slide_reach_m: a slide frame whose initial sole is higher than this was not followed
            by the fit (joint speed): its sole holds the nearest followed frame's footprint
            (:func:`imesh.solve.footprints.plan_footprints`) [m].
        slide_speed_m_s: a sliding or pivoting sole's footprint moves at most this fast
            [m/s]; where the fit's sole moves faster (a foot swept over the floor, a pivoting
            sole whipped round: the leap dance's right sole 6.5 m/s between two frames), the
            footprint follows it at this speed (:func:`~imesh.solve.footprints.plan_footprints`).
            A loaded sole dragged at the person's speed asks the legs for more than their
            joint limits: with every slide footprint at the fit's sole the leap dance's G1
            solve ended 25.7 mm into the ground with a joint past its limits (soles 69 mm off
            their footprints, accelerations 1.56 times the limits after 23 iterations); at
            1.5 m/s its written figures hold every gate but the marker RMS (179.9 mm), and
            salsa A's G1 file reads 65.3 mm instead of 76.4. At 1 m/s the leap's solve
            converges (170.0 mm), but the couple's window in docs/partners.md, whose
            partner B slides at 1-1.5 m/s, loses its held hands (G1 + G1: within 30 mm in
            80 % of the held samples instead of all). The zombie walk's slides (0.5-0.7 m/s)
            are below it.
    """

    clearance_m: float = 0.0
    swing_lift_m: float = 0.03
    swing_edge_m: float = 0.02
    lift_off_m: float = 0.01
    under_zmp: str = "slides"
    slide_reach_m: float = 0.05
    slide_speed_m_s: float = 1.5

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.under_zmp not in UNDER_ZMP:
            raise OptionError("under_zmp", self.under_zmp, UNDER_ZMP)
        if not self.slide_speed_m_s > 0:
            raise OptionError("slide_speed_m_s", self.slide_speed_m_s, "a speed > 0 [m/s]")


@dataclass(frozen=True)
class ForceOptions(NonNegative):
    """The ground's total force (:mod:`.forces`).

    Attributes:
        min_normal: the total normal force stays above this fraction of the weight
            (``g + c_z'' >= min_normal g``): the ground cannot pull, and a tracking controller
            whose feet carry less than this at a push-off leaves the ground.
        max_normal: ... and below this fraction (``g + c_z'' <= max_normal g``): the support
            joints carry at most this times the weight (a human walk stays within about 0.7
            and 1.3).
        friction: mu of the friction cone the ground's total horizontal force stays in (the
            evaluator's ``friction_ratio_max`` uses the same mu); 0: no friction rows.
        impact_normal: the upper bound within ``impact_s`` of a flight phase (take-off and
            landing: a 0.5 s leap leaves and meets the ground at 2.5 m/s, which 1.3 g cannot
            give or take in the support frames a clip has around it).
        impact_s: [s] before a take-off and after a landing.
        kinetic_friction: the largest mu of a sliding sole: where the only support slides, the
            ground's horizontal force is against the slide and at most ``kinetic_friction``
            times the normal force (a floor at most this rough); 0: no kinetic rows.
        yaw_sole_scale: in single support on the floor the ground's wrench stays inside the
            contact wrench cone of the support sole scaled by this about its centre (its yaw
            moment within ``yaw_sole_scale`` of what the sole's friction holds, the ZMP rows
            unchanged: :mod:`.cwc`); 0: no such rows. Without them the walks, veers and waves
            of docs/wholebody.md needed up to 1.85 times the friction a single support sole
            has (the evaluator's ``yaw_ratio``: G1 walk; beyond 1 in up to 16 frames a run),
            and in the DART check the stance sole turned under the robot; with them 0.42-0.52.
    """

    min_normal: float = 0.7
    max_normal: float = 1.3
    friction: float = 0.7
    impact_normal: float = 3.0
    impact_s: float = 0.3
    kinetic_friction: float = 0.3
    yaw_sole_scale: float = 0.5

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.max_normal < self.min_normal:
            raise OptionError("max_normal", self.max_normal,
                              f"a number >= min_normal ({self.min_normal})")
        if self.yaw_sole_scale > 1:
            raise OptionError("yaw_sole_scale", self.yaw_sole_scale, "a fraction in [0, 1]")
        if self.impact_normal < self.max_normal:
            raise OptionError("impact_normal", self.impact_normal,
                              f"a number >= max_normal ({self.max_normal})")


@dataclass(frozen=True)
class LimitMargins(NonNegative):
    """Room the written motion keeps from the robot's limits (:mod:`.limits`).

    Attributes:
        velocity: the joint speed limits are used times (1 - velocity): a controller tracking
            the motion needs speed to spare to catch up. At 1e-3 HRP-4C's walk ran a joint at
            its limit in 55 of 146 frames (the swing knee at 4.05 of 4.06 rad/s after each
            lift-off); in the DART check the simulated knee, starting a little behind, stayed
            0.4 rad behind and the foot dragged (largest key-point error 134 mm). At 0.3 the
            HRP-4C walk, veer and wave read 97.8, 84.9 and 88.8 mm (0.2: 111.7, 102.4, 90.0),
            their marker RMS 78.6, 95.1 and 69.8 mm (71.5, 91.2, 69.2 at 1e-3); the JVRC-1 and G1
            runs hardly touch their speed limits and barely change.
        acceleration: the acceleration limits are used times (1 - acceleration): room for a
            tracking controller, as the velocity margin. At 1e-3 the plan used them to the
            full at the lift-offs (JVRC-1's swing knee from 0.3 to 8 rad/s in two frames) and
            in the DART check the hip reached its torque limit following it; with the
            controller's earlier toe roll (its pitch held to the reference's) the JVRC-1
            veer's swing knee lagged 0.6 rad after its first lift-off, key points 112 mm off,
            80 mm at 0.3 (marker RMS +0.5-2.0 mm on the walks and veers).
        torque: the net joint torques (inverse dynamics, the base wrench split between the
            support soles as the evaluator's ``torque_ratio_ref``) stay within
            ``1 - torque`` of the effort limits (elastic rows, :mod:`.torque`); 1: no torque
            rows.
    """

    velocity: float = 0.3
    acceleration: float = 0.3
    torque: float = 0.15

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.torque > 1:
            raise OptionError("torque margin", self.torque, "a number in [0, 1]")


@dataclass(frozen=True)
class CollisionOptions:
    """Self-collision rows (docs/collision.md).

    Attributes:
        enabled: keep the robot's bodies apart: every checked capsule pair closer than
            ``self_activation_m`` gets a row ``d + J dq >= margin_m``, ``d`` the larger of the
            capsules' and the bodies' convex hulls' distance (:mod:`.collision`).
        margin_m: the signed distance the bodies keep [m].
        activation_m: links closer than this to a prop or a partner robot at the iterate get
            a row [m].
        self_activation_m: capsule pairs closer than this at the iterate get a self-collision
            row [m]. 5 cm: the rows keep the hulls apart, which lets an arm closer to the body
            than its capsules did, and a full step (0.3 rad) then carried a pair 2-5 cm apart
            on the capsules, without a row, through each other (Romeo's wave: a wrist 112 mm
            into the hip; every step length refused, the solve unconverged); at 2 cm the
            capsules' own rows held the arm back.
    """

    enabled: bool = True
    margin_m: float = 0.005
    activation_m: float = 0.02
    self_activation_m: float = 0.05

    def __post_init__(self) -> None:
        require_finite(self, ("activation_m", "self_activation_m"), positive=False)


@dataclass(frozen=True)
class SqpOptions:
    """The SQP's stopping rules, trust region and QP solver (:mod:`.sqp`, :mod:`.qp`).

    Attributes:
        iterations: largest number of SQP iterations.
        contact_iterations: largest number of SQP iterations of a plan with contacts the
            initial fit does not know: contact wrench cone rows (props, :mod:`.cwc`) or flight
            frames (:mod:`.forces`). A climb starts far from its tops and held points, and the
            holosoma seq_1 window still lowered its merit by 20-25 % per iteration at the 20th
            (soles 28 mm off, 75 frames outside the cone); salsa A (60_10, one flight) on G1
            read ZMP inside 0.918 on the written file after 20 iterations, 0.989 after 37
            (187 -> 399 s). Plans with slides alone keep ``iterations``: with 40 the salsa
            couple's hold (G1 + G1, no avoidance) ended with 4 frames over robot b's
            acceleration limits, and the zombie walk gained ZMP inside 0.969 -> 1.000 on G1
            for 2x the time.
        contact_gain: past ``iterations``, a plan with flight frames goes on only while each
            iteration lowers the merit by at least this fraction: the 60 s dance's windows
            holding two 2-frame flights, 3-5 % per iteration from the 20th to the 40th, stop at
            20 like its windows without flight (docs/clips-flight.md). Plans with prop
            contacts keep ``contact_iterations`` (a climb's window: 20-25 % at the 20th; not
            measured further).
        step_tolerance: stop when no coordinate of the update exceeds this [m or rad] ...
        merit_tolerance: ... or when the constraints hold (soles within 1 mm, ZMP and swing
            feet within 1 mm of their bounds) and an iteration lowered the merit by less than
            this fraction.
        settled_step: ... or when the constraints hold, as above and every other one the
            evaluator scores (joint velocity and acceleration limits, self-collision margins
            within 1 mm, torques), and no coordinate of the update exceeded this [m or rad]:
            the tail of iterations after that moves the key points by hundredths of a
            millimetre (G1 walk: 18 -> 11 iterations, marker RMS 48.18 -> 48.22 mm).
        margin_use: ... or when the soles are within 1 mm of their footprints, the swing feet
            clear, the key points settled (``keypoint_change``) and the other constraints hold
            with at most this fraction of the plan's margins used: the ZMP outside its shrunk
            polygon by at most ``margin_use`` of the distance the ZMP margin keeps from the
            soles' edges (``ZmpOptions.margin`` times the soles' smallest half size), the
            joint speeds, accelerations and torques within ``margin_use`` of their margins
            (``LimitMargins``), the cone rows beyond theirs by at most the same distance of the
            centre of pressure, self-collision as for ``settled_step``. The margins are room
            for the tracking controller, not targets to reach to the millimetre: the QP has no
            curvature of the ZMP, normal-force and cone rows, so their last millimetres
            converge linearly (JVRC-1 walk: -10 % per iteration over iterations 8-20) while
            the key points stay where they are.
        keypoint_change: the key points have settled when an iteration changed their RMS
            distance to the markers by less than this fraction.
        trust_region: largest change of any base or joint coordinate in one iteration [m or
            rad], so the linearization stays valid; each frame's and coordinate's radius
            adapts below it along the iterations (:mod:`.trust`).
        base_trust: the base translation's region is this fraction of ``trust_region`` [m].
        collision_trust: the largest radius of every coordinate of a frame whose
            self-collision distance is more than 1 mm inside its margin [m or rad]
            (:meth:`imesh.solve.trust.TrustRegion.capped`). The linearized distance has no
            curvature along the capsules' surfaces: a QP bounded by the 0.3 rad of
            ``trust_region`` slides the links along the tangent plane and the round capsules
            pass into each other again (salsa A on G1: the arm joints of output frame 235 moved
            0.12-0.3 rad at every iteration, the hands 40-56 mm into each other from the 2nd
            iteration to the 20th). 0: no cap.
        solver: QP solver, one of :data:`imesh.solve.qp.SOLVERS`.
        qp_tolerance: absolute tolerance of each QP solve (primal and dual residuals and
            PIQP's duality gap). 1e-5 moves an update by at most 3e-5 from a 1e-9 solve on the
            G1 walk's QPs and saves 2-4 of their 25-27 interior-point iterations; at 1e-7 one
            of them stalled (80 iterations and a retry of 30, docs/speed.md).
    """

    iterations: int = 20
    contact_iterations: int = 40
    contact_gain: float = 0.1
    step_tolerance: float = 1e-4
    merit_tolerance: float = 3e-2
    settled_step: float = 1e-2
    margin_use: float = 0.25
    keypoint_change: float = 5e-3
    trust_region: float = 0.3
    base_trust: float = 0.2
    collision_trust: float = 0.1
    solver: str = "piqp"
    qp_tolerance: float = 1e-5

    def __post_init__(self) -> None:
        require_count(self, ("iterations", "contact_iterations"))
        require_finite(self, ("step_tolerance", "qp_tolerance", "merit_tolerance"),
                       positive=True)
        require_finite(self, ("trust_region", "base_trust", "settled_step", "keypoint_change",
                              "collision_trust"), positive=False)
        if not 0.0 <= self.contact_gain < 1.0:
            raise OptionError("contact_gain", self.contact_gain, "a fraction in [0, 1)")
        if not 0.0 <= self.margin_use <= 1.0:
            raise OptionError("margin_use", self.margin_use, "a fraction in [0, 1]")
        if self.solver not in SOLVERS:
            raise OptionError("solver", self.solver, SOLVERS)


@dataclass(frozen=True)
class WindowOptions:
    """A long solve in overlapping windows (:mod:`imesh.solve.windows`).

    Attributes:
        frames: a whole-body solve longer than this many frames (lead-in/out included) is made
            in overlapping windows of at most this length: memory stays that of one window and
            time grows linearly; 900 frames (30 s at 30 fps) keeps every shared clip but the
            long idle in one window.
        overlap_frames: frames at the end of a window solved again by the next.
        workers: processes of a windowed solve: 1 (the windows in order) or 2 (two chains of
            windows in two processes joined by a window held at both ends,
            :func:`imesh.solve.windows.solve_windowed`). 1 by default: two cost 1.25x the cpu
            and were not faster on a shared 2-core machine (docs/speed.md); they pay only with
            a free core. A solve of one window ignores it.
    """

    frames: int = 900
    overlap_frames: int = 60
    workers: int = 1

    def __post_init__(self) -> None:
        require_count(self, ("overlap_frames",), minimum=2)
        # a window holds its first 4 frames at the previous window's and overlaps the next
        require_count(self, ("frames",), minimum=2 * (self.overlap_frames + 4))
        if type(self.workers) is not int or self.workers not in (1, 2):
            raise OptionError("workers", self.workers,
                              "1 (windows in order) or 2 (two chains in two processes)")


@dataclass(frozen=True)
class WholeBodyConfig:
    """Settings of the whole-body solve, one part per concept.

    Attributes:
        costs: weights of the objective's terms.
        zmp: the ZMP's cost and support-polygon rows.
        slack: prices of the constraints' slack.
        feet: heights of the swing soles.
        forces: the ground's normal force and friction.
        margins: room kept from the velocity, acceleration and torque limits.
        collision: self-collision rows.
        sqp: stopping rules, trust region and QP solver.
        initial_lowpass_hz: cut-off of the low-pass applied to the initial fit before the
            solve [Hz] (:func:`imesh.solve.initial.smooth_initializer`).
    """

    costs: CostWeights = field(default_factory=CostWeights)
    zmp: ZmpOptions = field(default_factory=ZmpOptions)
    slack: SlackPrices = field(default_factory=SlackPrices)
    feet: FootOptions = field(default_factory=FootOptions)
    forces: ForceOptions = field(default_factory=ForceOptions)
    margins: LimitMargins = field(default_factory=LimitMargins)
    collision: CollisionOptions = field(default_factory=CollisionOptions)
    sqp: SqpOptions = field(default_factory=SqpOptions)
    initial_lowpass_hz: float = 4.0

    def __post_init__(self) -> None:
        require_finite(self, ("initial_lowpass_hz",), positive=False)
