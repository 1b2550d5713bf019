"""The paper's benchmark problems (Zapico-Valle et al. 2010) and the ``femupdate
bench`` runs of them."""
