"""The two-storey shear building the workflow and posterior tests update: its model,
parameters and records, up to the [objective] each test file chooses."""

TRUTH = {"k1": 4000.0, "k2": 2500.0, "c1": 1.2, "c2": 0.6}

MODEL_AND_DATA = """\
[case]
name = "two-storey"

[model.shear_building]
masses = [1.0, 0.8]
stiffnesses = ["k1", "k2"]
dampers = ["c1", "c2"]

[[parameters]]
name = "k1"
lower = 1000.0
upper = 10000.0
scale = "log"
[[parameters]]
name = "k2"
lower = 1000.0
upper = 10000.0
scale = "log"
[[parameters]]
name = "c1"
lower = 0.0
upper = 5.0
[[parameters]]
name = "c2"
lower = 0.0
upper = 5.0

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
