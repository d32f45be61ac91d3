"""What a run's records mean, in plain Python (no JAX): the rules and words shared by the loop
that writes them, and the report and claims suite that read them.

* `litl.records.stuck`: a seed that ends stuck, and the result it still has;
* `litl.records.provenance`: which litl made a run, and on which processor;
* `litl.records.formatting`: numbers for people (the progress line, the report's tables).
"""
