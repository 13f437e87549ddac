"""A job carries the machine it was planned for (Machine.text()), and the
serial bridge refuses one planned for another machine than its own: its
steps would be reported as other millimetres.  Pure: no ROS."""
import pytest

from plotter_bridge.motion.kinematics import HangingGeometry, Machine


def test_the_same_machine_is_accepted_and_an_unsaid_one_is_not_checked():
    m = Machine(steps_per_mm=80.0)
    assert m.refuses(m.text()) is None
    assert m.refuses(Machine().text()) is None
    assert m.refuses("") is None


def test_integer_and_float_values_of_one_number_are_one_machine():
    assert Machine(steps_per_mm=100).text() == Machine(steps_per_mm=100.0).text()


@pytest.mark.parametrize("planned, own, names", [
    (Machine(steps_per_mm=100.0), Machine(steps_per_mm=80.0), ["steps_per_mm 100.0 in the job, 80.0 here"]),
    (Machine(steps_per_mm=80.00001), Machine(steps_per_mm=80.0), ["steps_per_mm 80.00001 in the job, 80.0 here"]),
    (Machine(kind="hanging"), Machine(), ["machine hanging in the job, cartesian here",
                                          "pulley_left [-150.0,1150.0] in the job, unset here",
                                          "steps_per_mm unset in the job, 80.0 here"]),
    (Machine(kind="hanging", hanging=HangingGeometry(pulses_per_rev=1600.0)), Machine(kind="hanging"),
     ["pulses_per_rev 1600.0 in the job, 3200.0 here"]),
    (Machine(z_mode="axis"), Machine(), ["z_mode axis in the job, pen here",
                                         "z_steps_per_mm 400.0 in the job, unset here"]),
    (Machine(z_mode="axis", z_steps_per_mm=200.0), Machine(z_mode="axis"),
     ["z_steps_per_mm 200.0 in the job, 400.0 here"]),
])
def test_another_machine_is_refused_naming_each_difference(planned, own, names):
    why = own.refuses(planned.text())
    assert why is not None and why.startswith("the job was planned for another machine: ")
    for name in names:
        assert name in why, why
    assert "same machine parameters" in why


def test_parameters_the_machine_kind_does_not_use_are_not_compared():
    # A cartesian machine's pulleys and a machine without a Z axis's Z scale
    # turn no step into millimetres.
    assert Machine(hanging=HangingGeometry(left=(0.0, 1.0))).refuses(Machine().text()) is None
    assert Machine(z_steps_per_mm=1.0).refuses(Machine().text()) is None
    assert Machine(kind="hanging", steps_per_mm=5.0).refuses(Machine(kind="hanging").text()) is None


@pytest.mark.parametrize("bad", ["cartesian", "machine=cartesian steps_per_mm", "\x00"])
def test_a_machine_text_that_is_not_name_value_words_is_refused(bad):
    why = Machine().refuses(bad)
    assert why is not None and "not name=value words" in why
