"""Host SDK for OpenShoe modules, real or emulated."""
