"""Reporting: the HTML report, the README's generated result blocks and the typed-number scanner."""
