"""Error models and covariances measured beside the product's and set aside: plug-ins for
``benchmarks/posterior.py`` (:func:`error_models.kinds.registry`)."""
