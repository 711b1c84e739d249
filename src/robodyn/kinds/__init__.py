"""The seed systems: closed forms written once, parameter extractors, user formula files, the check."""
