"""What an identified model predicts: nonlinear frequency responses by harmonic balance and continuation."""
