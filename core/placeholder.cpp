namespace lt { int corePlaceholder() { return 0; } }
