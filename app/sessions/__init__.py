"""Sessions on disk: the store, its database, evidence in words."""
