"""The fit store: fitted estimators kept on disk and read back instead of refitted.

A fit's key is what determines its result (the estimator's class and parameters, the training
arrays, the code: :func:`code_sources`, the model, feature and evaluation packages with their
sub-packages); nothing about the study or command that asks is in it, so the same fit asked
for by several tables, studies or runs is computed once. An estimator's ``memory`` parameter names
the cache folder (``memory=None``: ``$TZSL_CACHE_DIR`` when set, else no store; the PHAC-2 studies'
attribute banks: the cache folder of :func:`tzsl.cache.get_cache_dir`); the store is its
:data:`FITS_FOLDER` sub-folder, pruned with the study cache to one size cap (:mod:`tzsl.cache`).
The implementation, with the seeding and parallel helpers the attribute models share, is the
private ``tzsl._fit_store``.
"""

from tzsl._fit_store import FITS_FOLDER, code_sources, count_fits, fit_cached, fit_store_counts, resolve_store

__all__ = ["FITS_FOLDER", "code_sources", "count_fits", "fit_cached", "fit_store_counts", "resolve_store"]
