"""Rotor finite-element model (paper Sec. 2.2, Eq. 8-10): Timoshenko shaft, rigid discs, linear bearings.

SI units throughout; speeds and frequencies in rad/s (`*_hz` properties where a result is usually
read in Hz). Nodes are numbered from 1 as in the paper; DOFs per node are (x, y, theta_x, theta_y),
see `elements` for the sign convention of the rotations.
"""

from .assembly import Rotor, as_bearings, assemble, bearing_matrices, isotropic, rotor_from_machine
from .directional import directional_components, forward_backward_ratio, orbit_angle, unwrap_orbit_angle
from .elements import (DOF_PER_NODE, LinearBearing, RigidDisc, TimoshenkoBeam, cowper_shear_coefficient,
                       node_dofs)
from .modal import CampbellResult, ModalResult, campbell, modal_analysis
from .response import (Unbalance, UnbalanceResponse, dynamic_stiffness, machine_unbalance, unbalance_force,
                       unbalance_response, unbalance_sweep)
from .statics import (Reactions, StaticDeflection, gravity_load, simple_support_reactions, static_deflection,
                      weight)

__all__ = [
    "DOF_PER_NODE", "CampbellResult", "LinearBearing", "ModalResult", "Reactions", "RigidDisc", "Rotor",
    "StaticDeflection", "TimoshenkoBeam", "Unbalance", "UnbalanceResponse", "as_bearings", "assemble",
    "bearing_matrices", "campbell", "cowper_shear_coefficient", "directional_components", "dynamic_stiffness",
    "forward_backward_ratio", "gravity_load", "isotropic", "machine_unbalance", "modal_analysis", "node_dofs",
    "orbit_angle", "rotor_from_machine", "simple_support_reactions", "static_deflection", "unbalance_force",
    "unbalance_response", "unbalance_sweep", "unwrap_orbit_angle", "weight",
]
