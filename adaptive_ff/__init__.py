"""Identification of sliding dynamic friction and adaptive friction feedforward (Ruderman's method)."""
