"""Rod-pump helpers: synthetic pumping-unit kinematics, cards and fields of wells."""
