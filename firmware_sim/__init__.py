"""The emulated OpenShoe module (µC runtime, firmware, sensors, transports)."""
