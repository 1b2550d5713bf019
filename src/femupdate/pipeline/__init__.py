"""The commands' pipelines: a run (search, verdict, Laplace, summary), the
posterior, and the typed results they write."""
