"""Instruments that measure a running lattice: probes (a particle's motion and spectrum) and the
intensity screen."""
