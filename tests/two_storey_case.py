"""The two-storey shear building that many tests update: its model, parameters and records,
as pieces a test file puts together with the [search], [objective] or edits it needs."""

TRUTH = {"k1": 4000.0, "k2": 2500.0, "c1": 1.2, "c2": 0.6}

MODEL = """\
[case]
name = "two-storey"

[model.shear_building]
masses = [1.0, 0.8]
stiffnesses = ["k1", "k2"]
dampers = ["c1", "c2"]
"""


def parameters(log_stiffness: bool = False) -> str:
    """``[[parameters]]`` of k1, k2 (on a log scale if asked) and c1, c2."""
    scale = 'scale = "log"\n' if log_stiffness else ""
    return "".join(f'[[parameters]]\nname = "{name}"\nlower = {low}\nupper = {high}\n'
                   + (scale if name.startswith("k") else "")
                   for name, low, high in (("k1", 1000.0, 10000.0), ("k2", 1000.0, 10000.0),
                                           ("c1", 0.0, 5.0), ("c2", 0.0, 5.0)))


#: ``[data]``: the table record and both floors' accelerations, CSV files in ``data/``.
DATA = """\
[data]
format = "csv"
directory = "data"
time_column = "t"

[data.input]
file = "table.csv"
column = "table"

[[data.outputs]]
file = "floors.csv"
column = "a1"
node = "F1"
dof = "ux"
[[data.outputs]]
file = "floors.csv"
column = "a2"
node = "F2"
dof = "ux"
"""

MODEL_AND_DATA = MODEL + "\n" + parameters(log_stiffness=True) + "\n" + DATA + "\n"
