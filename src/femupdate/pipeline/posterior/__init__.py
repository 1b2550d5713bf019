"""The full posterior of a case and what it predicts: TMCMC through the run machinery
(``femupdate posterior``), predictive bands, model-class selection, console output."""
