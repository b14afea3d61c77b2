"""Configuration: docs/method.md defaults, validation that names the field, variants."""

import dataclasses
import math

import pytest

from dsmpepc_nlp.core.config import (
    BoundsConfig,
    ControlLawConfig,
    HorizonConfig,
    PlannerConfig,
    RobotConfig,
    RobotState,
)
from dsmpepc_nlp.core.cost_config import CostConfig, SmoothingConfig
from dsmpepc_nlp.core.errors import InputError
from dsmpepc_nlp.core.solver_config import SolverConfig


def test_defaults_are_the_methods():
    cfg = PlannerConfig()
    assert (cfg.control_law.k1, cfg.control_law.k2, cfg.control_law.beta) == (1.5, 3.0, 0.4)
    # The ramp is the robot's own (v_limit^2 / accel_limit, ours); the paper keeps IROS 2012's.
    assert cfg.control_law.lam == 2.0 and cfg.control_law.r_thresh_from_robot
    assert cfg.control_law.r_thresh == cfg.robot.v_limit ** 2 / cfg.robot.accel_limit
    assert PlannerConfig.paper().control_law.r_thresh == 1.2
    assert (cfg.horizon.dt, cfg.horizon.n_steps) == (0.2, 25)
    assert (cfg.cost.a, cfg.cost.s_ttc, cfg.cost.s_ttg) == (0.7, 0.5, 1e-3)
    assert (cfg.cost.sigma_static, cfg.cost.sigma_dynamic) == (0.1, 0.2)
    assert (cfg.cost.c_heading, cfg.cost.c_v, cfg.cost.c_w) == (0.2, 0.2, 0.1)
    # The collision weight is ours (docs/experiments/2026-11-25-heavier-collision-weight.md);
    # the paper preset keeps IROS 2012's.
    assert cfg.cost.c_collision == 0.3 and PlannerConfig.paper().cost.c_collision == 0.1
    assert cfg.z_upper == (8.0, 1.0, 1.8, cfg.robot.v_limit)
    assert cfg.docking.radius == 2.0


def test_variants_differ_only_in_the_two_switches():
    names = ("mpepc", "ds-mpepc", "pc-only", "terminal-only")
    configs = [PlannerConfig.variant(name) for name in names]
    assert [c.variant_name for c in configs] == list(names)
    assert PlannerConfig.mpepc() == configs[0] and PlannerConfig.ds_mpepc() == configs[1]
    stripped = {dataclasses.replace(c, anticipatory_pc=True, terminal_cost=True) for c in configs}
    assert len(stripped) == 1
    with pytest.raises(ValueError, match="variant"):
        PlannerConfig.variant("dwa")


@pytest.mark.parametrize(
    ("make", "field"),
    [
        (lambda: RobotConfig(v_limit=-1.0), "v_limit"),
        (lambda: RobotConfig(omega_limit=math.nan), "omega_limit"),
        (lambda: RobotConfig(footprint=((0.0, 0.0, -0.1),)), "footprint"),
        (lambda: RobotConfig(footprint=()), "footprint"),
        (lambda: RobotConfig(footprint=((0.0, 0.0),)), "footprint"),
        (lambda: ControlLawConfig(k1=0.0), "k1"),
        (lambda: ControlLawConfig(r_thresh="far"), "r_thresh"),
        (lambda: HorizonConfig(n_steps=0), "n_steps"),
        (lambda: HorizonConfig(n_steps=2.5), "n_steps"),
        (lambda: HorizonConfig(dt=math.inf), "dt"),
        (lambda: BoundsConfig(r_min=2.0, r_max=1.0), "r_max"),
        (lambda: CostConfig(a=1.5), "a"),
        (lambda: CostConfig(s_ttc=0.0), "s_ttc"),
        (lambda: SmoothingConfig(distance=-0.1), "distance"),
        (lambda: PlannerConfig(anticipatory_pc=1), "anticipatory_pc"),
        (lambda: PlannerConfig(robot="big"), "robot"),
        (lambda: RobotState(0.0, math.inf, 0.0), "y"),
        (lambda: SolverConfig(method="bfgs"), "method"),
        (lambda: SolverConfig(n_samples=0), "n_samples"),
        (lambda: SolverConfig().replace(n_solved=0), "n_solved"),
        (lambda: SolverConfig().replace(polish_ahead="yes"), "polish_ahead"),
        (lambda: SolverConfig().replace(screen_ahead=1), "screen_ahead"),
    ],
)
def test_invalid_values_raise_naming_the_field(make, field):
    with pytest.raises(ValueError, match=rf"\.{field} = .*must be"):
        make()


def test_infinite_rate_limits_are_allowed_and_replace_works():
    robot = RobotConfig(accel_limit=math.inf, alpha_limit=math.inf)
    cfg = dataclasses.replace(PlannerConfig(), robot=robot)
    assert cfg.robot.accel_limit == math.inf
    assert dataclasses.replace(cfg.cost, s_ttc=0.3).s_ttc == 0.3


def test_footprint_radii():
    robot = RobotConfig(footprint=((-0.2, 0.0, 0.2), (0.2, 0.0, 0.2)))
    assert robot.inflation_radius == pytest.approx(0.2)
    assert robot.bounding_radius == pytest.approx(0.4)


def test_the_ramp_follows_the_robot_and_a_set_ramp_is_not_silently_replaced():
    from dsmpepc_nlp.bench.params import configure

    fast = dataclasses.replace(PlannerConfig(), robot=RobotConfig(v_limit=2.0, accel_limit=2.5))
    assert fast.control_law.r_thresh == pytest.approx(2.0 ** 2 / 2.5)
    unlimited = PlannerConfig(robot=RobotConfig(accel_limit=math.inf))
    assert unlimited.control_law.r_thresh == 1.2          # no braking limit: IROS 2012
    assert dataclasses.replace(PlannerConfig(), robot=unlimited.robot).control_law.r_thresh == 1.2
    with pytest.raises(InputError, match="r_thresh_from_robot"):
        configure({"control_law.r_thresh": 0.9}, "ds-mpepc")
    own = configure({"control_law.r_thresh": 0.9, "control_law.r_thresh_from_robot": 0},
                    "ds-mpepc")
    assert own.control_law.r_thresh == 0.9
    # switched off on the command line: IROS 2012's ramp, not the number derived before
    off = configure({"control_law.r_thresh_from_robot": 0}, "ds-mpepc")
    assert not off.control_law.r_thresh_from_robot and off.control_law.r_thresh == 1.2
    assert configure({"control_law.r_thresh": 0.9}, "ds-mpepc", "paper").control_law.r_thresh \
        == 0.9
