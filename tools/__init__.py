"""Tools beyond the packages: conformance suite, benchmarks, converters."""
