"""Case files: one model-updating job described in TOML, validated once, at the edge.

A case file names the structural model, the parameters to update and their bounds, the measured
data, the signal processing, the error function, the integrator and the search. The package is
laid out by job:

- ``fields``: the field types (numbers with ranges and units, names, columns, delays);
- ``schema`` and ``model_sections``: the sections as pydantic models, ``Case`` the whole file;
- ``checks`` and ``issues``: what one field cannot check alone, and its wording;
- ``load``: ``load_case`` (TOML) and ``parse_case`` (a mapping), with messages that name file,
  field and allowed values;
- ``simulation_path``: which simulation path the case's fields choose (no model is built);
- ``model3d``, ``frame3d_case``, ``posterior_section``: 3-D frames and ``[posterior]``.

Schema and validation only: building the model and simulating it is
:mod:`femupdate.problem.case_model` (``CaseModel``, ``build_structure``), which this package
never imports. ``docs/case-files.md`` documents every field. Numbers of the model may name a
parameter declared in ``[[parameters]]`` (``k = "kp2"``); the built structure substitutes them
at every evaluation.
"""

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
    "format_value",
    "load_case",
    "parse_case",
]
