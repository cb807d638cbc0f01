"""State-space models for the estimators (continuous-time kinematics, measurement functions)."""
