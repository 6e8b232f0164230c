"""Test-suite settings: hypothesis runs derandomized and without a local example
database, so every machine (and CI) runs exactly the same examples."""

from hypothesis import settings

settings.register_profile("deterministic", derandomize=True, database=None)
settings.load_profile("deterministic")
