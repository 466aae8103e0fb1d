"""Front-end layer: the surface syntax of a `.stl` file.

``syntax`` parses source text (the Lark grammar in ``grammar/stl.lark``, with the post-lexer
``postlex``) into the syntax tree of ``ast``; ``printer`` prints a tree back as source text.
"""
