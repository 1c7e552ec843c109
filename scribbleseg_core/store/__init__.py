"""What the engine produces, on disk: trained model folders and app sessions."""
