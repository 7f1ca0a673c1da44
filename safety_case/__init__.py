"""The YAML safety-case language: schema, loading with positions, the GSN graph and its checks."""
