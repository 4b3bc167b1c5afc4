"""The restoring force's model: the term language, oscillator physics, structures, statics and modes."""
