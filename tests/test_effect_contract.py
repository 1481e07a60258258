"""Every registered effect, built in or a plugin's, and every effect a net implies, held to the
effect contract on its own example scene (cosnet.studies.effect_check): loads minus the
gradient of its energy where it says it is conservative (central differences; what they leave
is truncation and round-off, ~1e-10 of the loads), no net force or moment where it says it is
internal (round-off), a checkpoint round trip that continues its kernel bit for bit,
corrupted index tables refused before a run, and, its example's lines set swinging, an energy
balance (energy minus the work accounts plus what it dissipates) whose drift falls at the
scheme's order 2. The checks themselves are held to effects broken on purpose: each must
fail."""

import numpy as np
import pytest

import cosnet
from cosnet.effects.contact import Contact
from cosnet.effects.loads import Damping, Gravity
from cosnet.effects.obstacles import Obstacle
from cosnet.engine.registry import catalogue, implied_classes
from cosnet.studies import effect_check
from cosnet.studies.effect_check import check_effect

EFFECTS = [*catalogue().values(), *implied_classes()]
GRADIENT = 1e-7      # central differences at h = 1e-6: (h)^2 truncation, eps E / h round-off
ROUND_OFF = 1e-12


def test_every_effect_gives_an_example_to_be_checked_on():
    missing = [cls.__name__ for cls in EFFECTS if cls.example() is None]
    assert not missing, f"effects without an example scene (Effect.example): {missing}"


@pytest.mark.parametrize("cls", EFFECTS, ids=lambda c: c.__name__)
def test_effect_keeps_its_contract(cls):
    net, effects = cls.example()
    sim = cosnet.Simulation(net, effects)
    effect = next(e for e in sim.effects if type(e) is cls)
    r = check_effect(cls)
    if effect.conservative and cls.stage == "load":
        assert r.gradient_error < GRADIENT, r
    if effect.internal and cls.stage == "load":
        assert r.force_sum < ROUND_OFF and r.moment_sum < ROUND_OFF, r
    if cls.stage == "load":
        assert r.checkpoint_exact, r
    assert r.unrefused == [], f"{cls.__name__}: table_error lets these planted entries through: {r.unrefused}"
    assert r.unsaved == [], f"{cls.__name__}: its checkpoint leaves out the accounts {r.unsaved}"


@pytest.mark.parametrize("cls", EFFECTS, ids=lambda c: c.__name__)
def test_effect_balance_drifts_at_order_two(cls):
    """Position Verlet's energy error is O(dt^2): at 1/10 and 1/40 of the stable step the
    largest drift of the balance falls 16 times (order 2 +- 0.1, the wander of an oscillating
    error's maximum). An account that misses work (a slider's catch, the entrained fluid's
    energy as the added mass changes) leaves a drift the step does not shrink: order ~0."""
    assert 1.9 < check_effect(cls, dynamics=True).energy_order < 2.1


class UncountedDamping(Damping):
    """Damping whose dissipated energy no account holds."""

    def dissipated(self, sim):
        return 0.0


def test_the_conservative_effects_are_checked():
    """The gradient check is not vacuous: gravity, contact, obstacles, penalty joints, bodies
    and articulated ends all take it."""
    checked = {cls.__name__ for cls in EFFECTS if check_effect(cls).gradient_error is not None}
    assert {"Gravity", "Contact", "Obstacle", "SphericalJoint", "HingeJoint", "FixedJoint", "Body",
            "Articulations"} <= checked


class DoubledEnergy(Gravity):
    """Gravity whose potential is twice the one its kernel's force derives from."""

    def potential(self, p, on):
        return 2.0 * super().potential(p, on)


class UncheckedContact(Contact):
    """Contact that no longer checks its tables."""

    @staticmethod
    def table_error(p, model):
        return None


class ForgetfulObstacle(Obstacle):
    """A frictional obstacle whose checkpoint leaves out the friction anchors it keeps."""

    @classmethod
    def example(cls):
        net, effects = Obstacle.example()
        return net, [cls("plane", k=1e4, mu_s=0.5, mu_k=0.4, point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))]

    def state_arrays(self, sim):
        return {}


def test_the_checks_fail_on_effects_broken_on_purpose():
    assert check_effect(DoubledEnergy).gradient_error > 0.4
    unrefused = {u.split(" = ")[0] for u in check_effect(UncheckedContact).unrefused}
    assert {"elements", "elem_index"} <= unrefused, unrefused
    assert check_effect(ForgetfulObstacle).checkpoint_exact is False
    assert check_effect(Obstacle).checkpoint_exact is True
    assert abs(check_effect(UncountedDamping, dynamics=True).energy_order) < 0.3


def test_effect_loads_run_one_effect_s_kernel_as_the_step_calls_it():
    """sim.effect_loads: the loads of one effect alone, from the kernel the step calls (its
    slot): gravity beside a damping and a node load gives m g at every vertex and M g at every
    node, and nothing of the others; the simulation's own loads are left as they were; an
    effect without a load kernel of its own, or a row outside the effects' slots, is refused."""
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), mass=2.0, inertia=(1.0, 1.0, 1.0))
    b = net.add_node((1.0, 0.0, 0.0), mass=3.0, inertia=(1.0, 1.0, 1.0))
    net.add_line(a, b, material=cosnet.Material(E=1e9, poisson=0.3, density=1000.0), section=cosnet.Circle(0.01),
                 elements=4)
    gravity, damping = Gravity((0.0, 0.0, -9.81)), Damping(1.0)
    sim = cosnet.Simulation(net, [cosnet.NodeLoad(b, force=(5.0, 0.0, 0.0)), gravity, damping])
    before = sim.loads.f.copy()
    loads = sim.effect_loads(gravity)
    m = sim.model
    np.testing.assert_array_equal(loads.f[:, 2], -9.81 * m.vertex_mass)
    np.testing.assert_array_equal(loads.node_f[:, 2], -9.81 * m.node_own_mass)
    assert not loads.f[:, :2].any() and not loads.node_f[:, :2].any() and not loads.tau.any()
    np.testing.assert_array_equal(sim.loads.f, before)
    with pytest.raises(ValueError, match="no load kernel of its own"):
        sim.effect_loads(damping)
    from cosnet.kernels.compose import run_slot   # a row outside the effects' slots is refused
    from cosnet.kernels.layout import typed_call
    for row in (0, sim.step_table[0].shape[0]):
        with pytest.raises(ValueError, match="no effect slot"):
            typed_call(run_slot, m, sim.state, loads, sim.step_table, sim.backend, row, 0.0)


def test_momentum_check_sees_a_force_without_its_reaction():
    """The crossing rods' contact loads sum to nothing; without those on the second rod (a
    kernel that forgot the reaction) the check sees a force and a moment."""
    sim, effect = effect_check.example_simulation(Contact)
    effect_check._perturb(sim, np.random.default_rng(0))
    loads = sim.effect_loads(effect)
    force, moment = effect_check.momentum_of(sim, loads)
    assert force < ROUND_OFF and moment < ROUND_OFF
    second = sim.vertex_range(sim.net.lines[1])
    assert np.abs(loads.f[second]).sum() > 0
    loads.f[second] = 0.0
    force, moment = effect_check.momentum_of(sim, loads)
    assert force > 0.5 and moment > 0.1
