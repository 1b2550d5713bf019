"""The error function of a case (the update problem, the objective) and what the
data determine (identifiability)."""
