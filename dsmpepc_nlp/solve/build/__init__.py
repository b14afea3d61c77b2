"""The problem compiled: CasADi's generated C with our fast paths spliced in (:mod:`.csource`),
one shared library per problem structure, built once and cached (:mod:`.compiled`), the
compiled problem and a solve's typed result (:mod:`.library`), and compiling in a child process
so that no plan waits for a compiler (:mod:`.background`). Where the files live, and what a key
depends on: :mod:`dsmpepc_nlp.core.compile_cache`."""
