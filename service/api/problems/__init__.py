"""Error answers: RFC 9457 problem+json bodies and their handlers, validation errors written
for users, and the OpenAPI document of the problems."""
