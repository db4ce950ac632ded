"""HTTP and WebSocket routes of the service, one module per resource."""
