"""piezotip: co-simulation of a robot fingertip that feels through a multimode piezoelectric sensor."""
