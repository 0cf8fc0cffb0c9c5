"""Reading measured logs (CSV/TXT/.mat/.npz) and the EMPS benchmark data."""
