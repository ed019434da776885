"""Storage: the one atomic writer every output file goes through."""
