"""Case files: one model-updating job described in TOML, validated once, at the edge.

A case file names the structural model, the parameters to update and their bounds, the measured
data, the signal processing, the error function, the integrator and the search. The package is
laid out by job:

- ``fields``: the field types (numbers with ranges and units, names, columns, delays);
- ``schema`` and ``model_sections``: the sections as pydantic models, ``Case`` the whole file;
- ``checks`` and ``issues``: what one field cannot check alone, and its wording;
- ``load``: ``load_case`` (TOML) and ``parse_case`` (a mapping), with messages that name file,
  field and allowed values;
- ``build``: the one adapter from a case to its structure, output DOFs and prepared simulator;
  ``released``: a multi-support model's structure with its moving supports released.

``docs/case-files.md`` documents every field. Numbers of the model may name a parameter declared
in ``[[parameters]]`` (``k = "kp2"``); the built structure substitutes them at every evaluation.
"""

from femupdate.case.build import CaseModel, build_structure
from femupdate.case.fields import DOF_NAMES, format_value
from femupdate.case.load import load_case, parse_case
from femupdate.case.model_sections import (
    Beam,
    Damper,
    Friction,
    Mass,
    Model,
    Node,
    OpenSeesSection,
    PythonModelSection,
    Rayleigh,
    ShearBuilding,
    Spring,
    Support,
    SupportGroup,
)
from femupdate.case.released import released_structure
from femupdate.case.schema import (
    Case,
    CaseInfo,
    Channel,
    Data,
    ObjectiveOptions,
    OutputChannel,
    Parameter,
    Preprocess,
    Search,
    Simulation,
    Trial,
    TrialSpec,
)
from femupdate.units import ACCELERATION_UNITS, TIME_UNITS

__all__ = [
    "ACCELERATION_UNITS",
    "DOF_NAMES",
    "TIME_UNITS",
    "Beam",
    "Case",
    "CaseInfo",
    "CaseModel",
    "Channel",
    "Damper",
    "Data",
    "Friction",
    "Mass",
    "Model",
    "Node",
    "ObjectiveOptions",
    "OpenSeesSection",
    "OutputChannel",
    "Parameter",
    "Preprocess",
    "PythonModelSection",
    "Rayleigh",
    "Search",
    "ShearBuilding",
    "Simulation",
    "Spring",
    "Support",
    "SupportGroup",
    "Trial",
    "TrialSpec",
    "build_structure",
    "format_value",
    "load_case",
    "parse_case",
    "released_structure",
]
