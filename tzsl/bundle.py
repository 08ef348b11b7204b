"""Model bundles, read and written from Python: kept for users' imports (``from tzsl.bundle import load_bundle``).

The bundle file moved to :mod:`tzsl.inference.bundle` (with the payload kinds beside it in
:mod:`tzsl.inference`: one module per kind); this module re-exports its names and those of
:mod:`tzsl.inference.skops_bundles` that it exported before. New code imports from there.
"""

from tzsl.inference.bundle import (
    BUNDLE_FORMAT,
    BUNDLE_FORMAT_VERSION,
    BUNDLE_KEY_ENV,
    BundleHeader,
    load_bundle,
    read_bundle_header,
    save_bundle,
)
from tzsl.inference.skops_bundles import EXTRA_TRUSTED_TYPES, TRUSTED_MODULE_PREFIXES, is_trusted_type

__all__ = [
    "BUNDLE_FORMAT",
    "BUNDLE_FORMAT_VERSION",
    "BUNDLE_KEY_ENV",
    "EXTRA_TRUSTED_TYPES",
    "TRUSTED_MODULE_PREFIXES",
    "BundleHeader",
    "is_trusted_type",
    "load_bundle",
    "read_bundle_header",
    "save_bundle",
]
