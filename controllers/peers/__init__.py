"""Peer compensators measured against the adaptive feedforward: Canudas de Wit et al. (1987) and a disturbance observer."""
