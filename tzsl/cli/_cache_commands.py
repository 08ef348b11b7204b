"""``tzsl cache info`` and ``tzsl cache prune``: the study cache and the fit store (:mod:`tzsl.cache`)."""

from __future__ import annotations

import click

from tzsl.cli._root import cli


def _non_negative(ctx, param, value):
    """``--older-than`` / ``--max-size``: a finite number >= 0 (:func:`tzsl.cache.check_size_gb`), else exit 2."""
    from tzsl.cache import check_size_gb  # noqa: PLC0415 (keep --help fast)

    if value is None:
        return None
    try:
        return check_size_gb(value)
    except ValueError:
        unit = "days" if param.name == "older_than" else "GB"
        raise click.BadParameter(f"{value!r}: give a number of {unit} >= 0") from None


@cli.group()
def cache() -> None:
    """The cache folder: the study cache (whole studies) and the fit store (fitted models).

    The folder is $TZSL_CACHE_DIR, else the user cache folder; TZSL_STUDY_CACHE=0 turns the study
    cache off. Both caches together are kept under a size cap ($TZSL_CACHE_MAX_GB; 'tzsl cache
    info' shows it), the least recently used entries removed first.
    """


@cache.command()
def info() -> None:
    """Show the cache folder, the size cap and, per cache, its size, entries and oldest entry."""
    from tzsl.cache import (  # noqa: PLC0415
        CACHE_DIR_ENV,
        CACHE_PARTS,
        MAX_SIZE_ENV,
        STUDIES_FOLDER,
        STUDY_CACHE_ENV,
        cache_info,
        format_age,
        format_size,
        get_cache_dir,
        size_cap_gb,
        study_cache_on,
    )

    root, cap = get_cache_dir(), size_cap_gb()
    click.echo(f"cache folder: {root} (set {CACHE_DIR_ENV} to move it)")
    click.echo(f"size cap: {cap:g} GB for both caches together (set {MAX_SIZE_ENV} to change it)")
    for part in cache_info(root):
        oldest = "" if part.oldest_age is None else f"; oldest last used {format_age(part.oldest_age)} ago"
        off = f" (off: {STUDY_CACHE_ENV}=0)" if part.part == STUDIES_FOLDER and not study_cache_on() else ""
        click.echo(f"{CACHE_PARTS[part.part]}{off}: {format_size(part.size)} in {part.n_entries} entries{oldest} "
                   f"({part.folder})")


@cache.command()
@click.option("--older-than", type=str, default=None, metavar="DAYS", callback=_non_negative,
              help="Remove every entry last used more than DAYS days ago.")
@click.option("--max-size", type=str, default=None, metavar="GB", callback=_non_negative,
              help="Then remove the least recently used entries until both caches hold at most GB gigabytes "
                   "(10^9 bytes). Default: the size cap ('tzsl cache info').")
def prune(older_than: float | None, max_size: float | None) -> None:
    """Remove the least recently used entries of the study cache and the fit store; print what went.

    Safe while studies run: an entry is written under a temporary name and moved into place in one
    step, a study being restored marks its entry used first, and an entry or temporary name used in
    the last minutes is never removed. Temporary names left by an interrupted run are removed.
    """
    from tzsl.cache import (  # noqa: PLC0415
        CACHE_PARTS,
        IN_USE_SECONDS,
        STUDIES_FOLDER,
        format_age,
        format_size,
        get_cache_dir,
        size_cap_gb,
    )
    from tzsl.cache import prune as prune_cache  # noqa: PLC0415

    limit = size_cap_gb() if max_size is None else max_size
    root = get_cache_dir()
    report = prune_cache(root, older_than_days=older_than, max_size_gb=limit)
    for entry in report.removed:
        if entry.part == STUDIES_FOLDER:
            click.echo(f"removed study cache entry {entry.path.name} ({format_size(entry.size)}, "
                       f"last used {format_age(report.now - entry.used)} ago)")
    for part, name in CACHE_PARTS.items():
        gone = [e for e in report.removed if e.part == part]
        if gone:
            ages = sorted(report.now - e.used for e in gone)
            click.echo(f"removed {len(gone)} {name} entries, {format_size(sum(e.size for e in gone))}, "
                       f"last used {format_age(ages[0])} to {format_age(ages[-1])} ago")
    if not report.removed:
        click.echo(f"nothing to remove in {root}")
    if report.kept_in_use:
        click.echo(f"kept {len(report.kept_in_use)} entries over the limit: used in the last "
                   f"{format_age(IN_USE_SECONDS)} (a study may be reading them)")
    click.echo(f"left: {format_size(report.remaining_size)} in both caches (limit {limit:g} GB)")
