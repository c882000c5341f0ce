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
The vehicle models, chosen once by name: the one table of the scenario parameter ``model``.

========================  =====================================  ================================
model                     ``U[0]``                               ``U[1]``
========================  =====================================  ================================
``first_order``  (1.1)    unused                                 turn rate theta' (rad/s)
``second_order`` (1.3)    unused                                 angular acceleration a (rad/s^2)
``rigid``        (6.15)   thrust T along body x (N)              steering force F at the tail (N)
``rigid_couple`` (8.22)   thrust T (N)                           moment-couple force F (N)
``rigid_cop``    (A.3)    thrust T (N)                           steering force F at the tail (N)
``vessel`` (Fossen)       surge force tau_u (N)                  yaw moment tau_r (N m)
========================  =====================================  ================================

Each is a :class:`base.VehicleModel` (one file per family: :mod:`particles`, :mod:`rigid`,
:mod:`vessel`);
the rest of the package asks the model object (``models.Plant.model``, :func:`vehicle_model`)
what it is and what it does, never its name.
"""
from __future__ import annotations

from formation_control.core.vehicles.base import VehicleModel
from formation_control.core.vehicles.particles import FirstOrder, SecondOrder
from formation_control.core.vehicles.rigid import Rigid, RigidCop, RigidCouple
from formation_control.core.vehicles.vessel import Vessel

VEHICLE_MODELS: dict[str, VehicleModel] = {
    m.name: m for m in (FirstOrder(), SecondOrder(), Rigid(), RigidCouple(), RigidCop(), Vessel())}
"""Every vehicle model by its name, in the order the docs list them."""
MODEL_NAMES = tuple(VEHICLE_MODELS)


def vehicle_model(name: str) -> VehicleModel:
    """
    Return the vehicle model named ``name`` (the scenario parameter ``model``).

    Raises
    ------
    ValueError
        ``name`` is no model's, with the names there are.

    """
    try:
        return VEHICLE_MODELS[name]
    except KeyError:
        raise ValueError(f'model {name!r} is not one of {", ".join(MODEL_NAMES)}') from None


def reading(param: str) -> tuple[str, ...]:
    """Return the names of the models that read the vehicle parameter ``param`` (m0, I0, ...)."""
    return tuple(m.name for m in VEHICLE_MODELS.values() if param in m.params)


def rigid_names() -> tuple[str, ...]:
    """Return the names of the models with body velocity rows and a thrust input."""
    return tuple(m.name for m in VEHICLE_MODELS.values() if m.rigid)
