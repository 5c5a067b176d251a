// Placeholder so the target exists before its issue lands; delete when the first real source is added.
