"""Language tools: ``stlc fmt``, ``stlc lsp``, ``stlc explain`` (the lexer is
``stlc.frontend.lexer``)."""
