"""Many runs: study configs, distributions, designs, the engine, critical inclines, assembly and Sobol runs."""
