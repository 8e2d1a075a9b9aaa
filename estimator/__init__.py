"""Oil-flow estimation: the augmented-state Extended Kalman Filter and the starvation alarm."""
