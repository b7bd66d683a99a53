"""The embedded backend: a batched numpy simulator (variations x actors x time) on the scenario's road network."""
