"""Built-in agents (the top-level agents/ folder, installed as nao_arena.agents)."""
