"""The compiled step of a model whose inputs fix its body twist, written once.

A rigid-body model's module defines ``body_twist(parameters, inputs) -> (v_x, v_y, omega)``
and takes :func:`advance`, :func:`twist` and :func:`rates` from here (``from
mobile_envs.robots.rigid_body import advance, rates, twist``): they are templates that
:func:`~mobile_envs._kernels.specialize.for_model` compiles with that ``body_twist``.
"""

from __future__ import annotations

from mobile_envs._kernels.angles import wrap_scalar_angle
from mobile_envs._kernels.specialize import model, per_model
from mobile_envs.robots.motion import body_rates, rigid_body_step


@per_model(inline="always")
def advance(parameters, state, inputs, dt, integrator_code, out):
    """Advance one robot by ``dt`` seconds under saturated ``inputs`` into ``out`` (which may
    be ``state``), the heading wrapped to (-pi, pi]."""
    v_x, v_y, omega = model.body_twist(parameters, inputs)
    x, y, heading = rigid_body_step(
        state[0], state[1], state[2], v_x, v_y, omega, dt, integrator_code
    )
    out[0] = x
    out[1] = y
    out[2] = wrap_scalar_angle(heading)


@per_model(inline="always")
def twist(parameters, state, inputs):
    """Forward speed v and yaw rate omega of one robot's reference point."""
    v_x, _, omega = model.body_twist(parameters, inputs)
    return v_x, omega


@per_model(inline="always")
def rates(parameters, state, inputs, out):
    """The time derivative of one robot's (x, y, heading) into ``out``."""
    v_x, v_y, omega = model.body_twist(parameters, inputs)
    out[0], out[1], out[2] = body_rates(state[2], v_x, v_y, omega)
