"""The structural model: element matrices, structures, assembly and modes.

``Structure`` describes a planar structure once and ``Structure.assemble`` turns parameter
values into the ``System`` (M, C, K, r, friction and Bouc–Wen elements) that the integrators
consume.
"""

from femupdate.model.elements import (
    beam_mass,
    beam_stiffness,
    frame_element,
    frame_mass,
    frame_rotation,
    frame_stiffness,
    lumped_mass,
    shear_parameter,
    spring,
    spring_matrix,
    timoshenko_beam,
)
from femupdate.model.modes import DampedModes, damped_modes, initial_stiffness, natural_frequencies
from femupdate.model.structure import DOF_NAMES, Structure, shear_building
from femupdate.model.system import BoucWenElements, FrictionElements, System

__all__ = [
    "DOF_NAMES",
    "BoucWenElements",
    "DampedModes",
    "FrictionElements",
    "Structure",
    "System",
    "beam_mass",
    "beam_stiffness",
    "damped_modes",
    "frame_element",
    "frame_mass",
    "frame_rotation",
    "frame_stiffness",
    "initial_stiffness",
    "lumped_mass",
    "natural_frequencies",
    "shear_building",
    "shear_parameter",
    "spring",
    "spring_matrix",
    "timoshenko_beam",
]
