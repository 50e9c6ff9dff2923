"""What ships beside the packages: the conformance suite (``openshoe-conformance``)."""
