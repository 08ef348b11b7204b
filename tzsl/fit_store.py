"""The fit store: fitted estimators kept on disk and read back instead of refitted.

A fit's key is what determines its result (the estimator's class and parameters, the training
arrays, the code); nothing about the study or command that asks is in it, so the same fit asked
for by several tables, studies or runs is computed once. ``$TZSL_CACHE_DIR`` (or an estimator's
``memory`` parameter) names the cache folder; the store is its :data:`FITS_FOLDER` sub-folder.
The implementation, with the seeding and parallel helpers the attribute models share, is the
private ``tzsl._fit_store``.
"""

from tzsl._fit_store import FITS_FOLDER, count_fits, fit_cached, fit_store_counts, resolve_store

__all__ = ["FITS_FOLDER", "count_fits", "fit_cached", "fit_store_counts", "resolve_store"]
