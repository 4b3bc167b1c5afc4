"""The force balance as least squares: regressors, honest standard errors, a structure's joint fit."""
