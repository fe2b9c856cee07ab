"""Link models in simulation time: UART, WiFi, LTE, SiK radio, wired (docs/links.md)."""
