namespace lt { int bsdfPlaceholder() { return 0; } }
